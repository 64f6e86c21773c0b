// The one-pass lean step's blocks (cuda/src/device_step_blocks.h), built on the host: every index
// a block's kernel reads resolves to the vertex, neighbour, cell and cell member the separate
// passes read. Runs without a GPU (the device side is tst_cuda_parity's, to the bit).
#include "device_step_blocks.h"
#include "parity_scene.h"

#include <QtTest>

using namespace sinew;
using namespace sinew::testing;

class TestStepBlocks : public QObject {
  Q_OBJECT
private slots:
  void blocksDescribeTheMesh() {
    auto sim = scene({"smoothing", "shape_prior"}, 4);
    for (int l = 0; l < 3; ++l) sim->advanceLevel();  // 102,400 vertices, 400 blocks
    const MeshStore& s = sim->store();
    const auto a = cuda::buildStepBlocks(s);
    QVERIFY(a.has_value());
    const int n = int(s.vertexCount()), blocks = (n + cuda::kStepBlock - 1) / cuda::kStepBlock;
    QCOMPARE(int(a->start.size()), blocks + 1);
    const auto next = s.neighbours();
    const auto cellsOf = s.vertexCells();
    const auto offsets = s.cellOffsets();
    const auto members = s.cellVertices();
    std::size_t outsideTotal = 0;
    for (int k = 0; k < blocks; ++k) {
      const auto at = a->start[k], end = a->start[k + 1];
      const int first = k * cuda::kStepBlock, count = std::min(cuda::kStepBlock, n - first);
      // Slot p's vertex: the block's own first, then the listed ones, each once.
      std::vector<int> vertexOf;
      for (int p = 0; p < count; ++p) vertexOf.push_back(first + p);
      for (int i = at[0]; i < end[0]; ++i) vertexOf.push_back(a->vertices[i]);
      std::vector<int> sorted = vertexOf;
      std::sort(sorted.begin(), sorted.end());
      QVERIFY(std::adjacent_find(sorted.begin(), sorted.end()) == sorted.end());
      const int geometries = end[1] - at[1], cells = end[2] - at[2];
      QVERIFY(geometries >= count && geometries <= int(vertexOf.size()));
      outsideTotal += geometries - count;
      for (int g = 0; g < geometries; ++g) {
        const int v = vertexOf[g];
        for (int j = 0; j < 3; ++j) {
          const int packed = a->geometry[at[1] + g][j], slot = packed & 0xffff, cell = packed >> 16;
          QCOMPARE(vertexOf[slot], int(next[v][j]));
          if (g < count) QVERIFY(slot < geometries);  // the own vertices' neighbours have their geometry
          QVERIFY(cell < cells);
          // The cell's members, in the cell's order.
          const int from = cell == 0 ? 0 : a->cellEnd[at[2] + cell - 1], to = a->cellEnd[at[2] + cell];
          const Index c = cellsOf[v][j];
          QCOMPARE(Index(to - from), offsets[c + 1] - offsets[c]);
          for (int i = from; i < to; ++i) QCOMPARE(vertexOf[a->cellSlots[at[3] + i]], int(members[offsets[c] + (i - from)]));
        }
      }
      // The block's arrays fit the shared layout's regions.
      const cuda::StepBlockLayout mine = cuda::stepBlockLayout(int(vertexOf.size()), cells, geometries, end[3] - at[3]);
      const cuda::StepBlockLayout& all = a->layout;
      QVERIFY(mine.centre - mine.pos <= all.centre - all.pos);
      QVERIFY(mine.previous - mine.centre <= all.previous - all.centre);
      QVERIFY(mine.area - mine.geometry <= all.area - all.geometry);
      QVERIFY(mine.cellSlots - mine.cellEnd <= all.cellSlots - all.cellEnd);
      QVERIFY(mine.words - mine.cellSlots <= all.words - all.cellSlots);
      // What the 16-byte-piece copies of the block's connectivity write fits its regions (the
      // uploaded arrays start on 256 bytes, so their offsets decide the pieces).
      QVERIFY(cuda::spanCopyWords(12LL * at[1], 12LL * geometries) <= all.area - all.geometry);
      QVERIFY(cuda::spanCopyWords(2LL * at[2], 2LL * cells) <= all.cellSlots - all.cellEnd);
      QVERIFY(cuda::spanCopyWords(2LL * at[3], 2LL * (end[3] - at[3])) <= all.words - all.cellSlots);
      QVERIFY(cuda::spanCopyWords(0, 12LL * cuda::kStepBlock) <= all.centre - all.pos);
      // Every region starts on 16 bytes (the kernel's 16-byte copies).
      for (const int region : {all.pos, all.centre, all.previous, all.geometry, all.area, all.elevation, all.mesh,
                               all.cellEnd, all.cellSlots, all.words})
        QCOMPARE(region % 4, 0);
    }
    qInfo("%d vertices in %d blocks: %.2f vertices outside a block have their geometry there, per own vertex; "
          "%zu listed positions, %zu bytes of shared memory at most",
          n, blocks, double(outsideTotal) / n, a->vertices.size(), 4 * std::size_t(a->layout.words));
  }
};

QTEST_APPLESS_MAIN(TestStepBlocks)
#include "tst_step_blocks.moc"
