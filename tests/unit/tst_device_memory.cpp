// Device out of memory (label gpu): a scene that does not fit in the GPU's free memory is refused
// with a message that says so, and the run goes on on the CPU; a finer level that does not fit
// fails cleanly at the level change; the device works again once memory is free. The test fills
// the device itself (the scene then asks for more than the device has), since a scene larger than
// an 80 GB GPU would not fit the host either.
#include "backend_choice.h"
#include "sinew/cuda/cuda_engine.h"
#include "synthetic.h"

#include <cuda_runtime.h>

#include <QtTest>

#include <tuple>

using namespace sinew;
using namespace sinew::testing;

namespace {
// Holds nearly all of the device's free memory while it lives.
class DeviceFiller {
public:
  DeviceFiller() {
    for (std::size_t chunk : {std::size_t(256) << 20, std::size_t(16) << 20, std::size_t(1) << 20, std::size_t(64) << 10}) {
      void* p = nullptr;
      while (cudaMalloc(&p, chunk) == cudaSuccess) blocks_.push_back(p);
      cudaGetLastError();
    }
  }
  ~DeviceFiller() {
    for (void* p : blocks_) cudaFree(p);
  }
  std::size_t blocks() const { return blocks_.size(); }

private:
  std::vector<void*> blocks_;
};

std::unique_ptr<Simulation> twoSpheres(int levels) {
  auto sim = std::make_unique<Simulation>(forceRegistry(), 0);
  for (auto [name, radius, x] : {std::tuple{"a", 10.0f, 0.0f}, std::tuple{"b", 8.0f, 30.0f}}) {
    StructureSpec s = sphereStructure(name, 3, radius, Vec3(x, 0, 0), levels);
    s.referencePositions = withNoise(s.initialPositions, 0.2f, 3);  // the shape prior's reference
    sim->addStructure(std::move(s));
  }
  sim->addForce("smoothing").setAll("weight", 0.3);
  sim->addForce("shape_prior").setAll("weight", 0.3);
  sim->setIntegrator("damped_verlet");
  sim->initialize();
  return sim;
}

bool finite(Simulation& sim) {
  for (const Vec3& v : sim.store().positions())
    if (!v.allFinite()) return false;
  return true;
}
}  // namespace

class TestDeviceMemory : public QObject {
  Q_OBJECT
private Q_SLOTS:
  void initTestCase() {
    const auto st = cuda::probeDevice();
    if (!st.usable) QSKIP(qPrintable("needs an NVIDIA GPU: " + QString::fromStdString(st.reason)));
  }

  void sceneLargerThanTheFreeMemoryRunsOnTheCpu() {
    auto sim = twoSpheres(1);
    std::string notice;
    std::unique_ptr<ExecutionBackend> backend;
    {
      DeviceFiller filler;
      QVERIFY(filler.blocks() > 0);
      backend = makeBackend("cuda", *sim, [&](const std::string& m) { notice = m; });
      QVERIFY2(!backend, "the CUDA engine started on a full device");
      qInfo("notice: %s", notice.c_str());
      QVERIFY2(notice.find("out of memory") != std::string::npos, notice.c_str());
      QVERIFY2(notice.find("MiB free of") != std::string::npos, notice.c_str());
      QVERIFY2(notice.find("running on the CPU") != std::string::npos, notice.c_str());
      sim->run(20);  // the CPU carries on
      QVERIFY(finite(*sim));
    }
    // Memory free again: the same process gets a working device.
    backend = makeBackend("cuda", *sim, [&](const std::string& m) { QFAIL(m.c_str()); });
    QVERIFY(backend);
    backend->run(20);
    backend->download();
    QVERIFY(finite(*sim));
  }

  void finerLevelThatDoesNotFitFailsCleanly() {
    auto sim = twoSpheres(3);
    cuda::CudaEngine engine(*sim);
    engine.run(10);
    engine.download();
    DeviceFiller filler;
    QVERIFY(sim->advanceLevel());
    QVERIFY(sim->advanceLevel());  // 16x the vertices of level 0
    try {
      engine.levelChanged();
      QFAIL("the finest level fitted on a full device");
    } catch (const std::runtime_error& e) {
      qInfo("level change: %s", e.what());
      QVERIFY2(std::string(e.what()).find("out of memory") != std::string::npos, e.what());
    }
    // The host state is whole: the CPU goes on (what SceneRunner and the workstation do).
    QVERIFY(finite(*sim));
    sim->run(10);
    QVERIFY(finite(*sim));
  }
};

QTEST_GUILESS_MAIN(TestDeviceMemory)
#include "tst_device_memory.moc"
