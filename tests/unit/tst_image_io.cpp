// The ITK image IO plugin: formats, physical space (LPS inside, RAS in NIfTI files, the sform over
// a qform that disagrees), anisotropic voxels, DICOM series, and refusals of bad files.
#include "synthetic.h"

#include <QTemporaryDir>
#include <QtTest>

#include <itkGDCMImageIO.h>
#include <itkImageFileReader.h>
#include <itkImageFileWriter.h>
#include <itkImageSeriesWriter.h>
#include <itkMetaDataObject.h>
#include <itkNiftiImageIO.h>
#include <itkNumericSeriesFileNames.h>

#include <zlib.h>

#include <fstream>
#include <iterator>

using namespace sinew;
using namespace sinew::testing;
namespace fs = std::filesystem;

namespace {

Image3D obliqueImage() {
  ImageGeometry g;
  g.size = {12, 10, 7};
  g.spacing = Eigen::Vector3d(1.37, 1.37, 5.0);  // the seed's anisotropic voxels
  g.origin = Eigen::Vector3d(-20.5, 13.25, 7.0);
  g.direction = Eigen::AngleAxisd(0.3, Eigen::Vector3d(1, 2, 3).normalized()).toRotationMatrix();
  Image3D im(g);
  for (int k = 0; k < 7; ++k)
    for (int j = 0; j < 10; ++j)
      for (int i = 0; i < 12; ++i) im.at(i, j, k) = float(i + 20 * j + 300 * k);
  return im;
}

void expectSameSpace(const Image3D& a, const Image3D& b) {
  QCOMPARE(a.geometry().size, b.geometry().size);
  QVERIFY((a.geometry().spacing - b.geometry().spacing).norm() < 1e-4);
  QVERIFY((a.geometry().origin - b.geometry().origin).norm() < 1e-3);
  QVERIFY((a.geometry().direction - b.geometry().direction).norm() < 1e-5);
  // The same world point holds the same value.
  const Vec3 world = a.indexToWorld(Vec3(3.25f, 4.5f, 2.75f));
  QVERIFY(std::abs(a.sample(world) - b.sample(world)) < 1e-2f);
}

void expectRefusal(const ImageIODescriptor& io, const fs::path& p, const QString& needle) {
  try {
    io.readImage(p);
    QFAIL(qPrintable("accepted " + QString::fromStdString(p.string())));
  } catch (const InputError& e) {
    const QString msg = e.what();
    QVERIFY2(msg.contains(QString::fromStdString(p.string())) && msg.contains(needle), qPrintable(msg));
  }
}

}  // namespace

class TestImageIO : public QObject {
  Q_OBJECT
  QTemporaryDir dir_;
  fs::path path(const char* name) { return fs::path(dir_.path().toStdString()) / name; }
  const ImageIODescriptor& io() { return builtinRegistry().imageIOFor("x.nii.gz"); }

private slots:
  void roundTripsKeepPhysicalSpace_data() {
    QTest::addColumn<QString>("name");
    for (const char* n : {"a.nii", "a.nii.gz", "a.nrrd", "a.mha", "a.mhd"}) QTest::newRow(n) << QString(n);
  }
  void roundTripsKeepPhysicalSpace() {
    QFETCH(QString, name);
    const Image3D im = obliqueImage();
    const fs::path p = path(name.toStdString().c_str());
    io().writeImage(p, im);
    expectSameSpace(im, io().readImage(p));
  }

  void niftiFilesStoreRas() {
    // ITK works in LPS; NIfTI stores RAS. The file's qoffset must be (-x, -y, z) of the LPS origin.
    ImageGeometry g;
    g.size = {4, 4, 4};
    g.origin = Eigen::Vector3d(10, 20, 30);
    Image3D im(g, 1.0f);
    const fs::path p = path("ras.nii");
    io().writeImage(p, im);
    std::ifstream f(p, std::ios::binary);
    char header[348];
    f.read(header, sizeof header);
    float q[3];
    std::memcpy(q, header + 268, sizeof q);  // qoffset_x, qoffset_y, qoffset_z
    QCOMPARE(q[0], -10.0f);
    QCOMPARE(q[1], -20.0f);
    QCOMPARE(q[2], 30.0f);
    QVERIFY((io().readImage(p).geometry().origin - g.origin).norm() < 1e-5);
  }

  void labelsRoundTrip() {
    LabelVolume labels(obliqueImage().geometry(), 0);
    labels.at(3, 4, 5) = 37;
    labels.at(0, 0, 0) = 78;
    const fs::path p = path("labels.nii.gz");
    io().writeLabels(p, labels);
    const LabelVolume back = io().readLabels(p);
    QCOMPARE(back.voxels(), labels.voxels());
    labels.at(1, 1, 1) = 70000;
    QVERIFY_THROWS_EXCEPTION(InputError, io().writeLabels(path("big.nii.gz"), labels));
    QVERIFY(!fs::exists(path("big.nii.gz")));
  }

  // NIfTI files of more than one slab (256 K voxels) are read a slab of slices at a time
  // (itk_image_io.cpp): every voxel must land where it belongs, the last, shorter slab's too, for a
  // float file, an 8-bit one (converted by the reader slab by slab) and a label map.
  void largeNiftiFilesReadInSlabs_data() {
    QTest::addColumn<QString>("kind");
    for (const char* k : {"float.nii", "uint8.nii.gz", "labels.nii.gz"}) QTest::newRow(k) << QString(k);
  }
  void largeNiftiFilesReadInSlabs() {
    QFETCH(QString, kind);
    ImageGeometry g;
    g.size = {64, 64, 70};  // 287 K voxels: slabs of 64 slices and 6
    g.spacing = Eigen::Vector3d(0.5, 0.5, 0.6);
    g.origin = Eigen::Vector3d(-40, -36, -60);
    const auto value = [](int i, int j, int k) { return (i * 7 + j * 13 + k * 31) % 251; };
    const fs::path p = path(qPrintable(kind));
    if (kind == "labels.nii.gz") {
      LabelVolume labels(g, 0);
      for (int k = 0; k < 70; ++k)
        for (int j = 0; j < 64; ++j)
          for (int i = 0; i < 64; ++i) labels.at(i, j, k) = value(i, j, k) + 1000 * (k % 7);
      io().writeLabels(p, labels);
      QCOMPARE(io().readLabels(p).voxels(), labels.voxels());
      return;
    }
    Image3D im(g);
    for (int k = 0; k < 70; ++k)
      for (int j = 0; j < 64; ++j)
        for (int i = 0; i < 64; ++i) im.at(i, j, k) = float(value(i, j, k)) + (kind == "float.nii" ? 0.25f * float(k) : 0.0f);
    if (kind == "float.nii") {
      io().writeImage(p, im);
    } else {
      using Bytes = itk::Image<unsigned char, 3>;
      auto bytes = Bytes::New();
      bytes->SetRegions(Bytes::SizeType{64, 64, 70});
      bytes->Allocate();
      std::transform(im.voxels().begin(), im.voxels().end(), bytes->GetBufferPointer(),
                     [](float v) { return static_cast<unsigned char>(v); });
      auto writer = itk::ImageFileWriter<Bytes>::New();
      writer->SetImageIO(itk::NiftiImageIO::New());
      writer->SetInput(bytes);
      writer->SetFileName(p.string());
      writer->UseCompressionOn();
      writer->Update();
    }
    QCOMPARE(io().readImage(p).voxels(), im.voxels());
  }

  void readsDicomSeries() {
    // A series written with ITK's GDCM writer, one file per slice, read back as one volume.
    using Slice = itk::Image<std::int16_t, 2>;
    using Volume = itk::Image<std::int16_t, 3>;
    const Image3D im = obliqueImage();
    auto volume = Volume::New();
    Volume::SizeType size;
    Volume::SpacingType spacing;
    Volume::PointType origin;
    for (int a = 0; a < 3; ++a) {
      size[a] = im.geometry().size[a];
      spacing[a] = im.geometry().spacing[a];
      origin[a] = im.geometry().origin[a];
    }
    volume->SetRegions(Volume::RegionType(size));
    volume->SetSpacing(spacing);
    volume->SetOrigin(origin);
    volume->Allocate();
    for (size_t i = 0; i < im.voxels().size(); ++i) volume->GetBufferPointer()[i] = std::int16_t(im.voxels()[i]);
    const fs::path series = path("dicom");
    fs::create_directories(series);
    auto names = itk::NumericSeriesFileNames::New();
    names->SetSeriesFormat((series / "slice%03d.dcm").string());
    names->SetStartIndex(0);
    names->SetEndIndex(size[2] - 1);
    names->SetIncrementIndex(1);
    // Each slice carries its own position, as a scanner writes it.
    std::vector<itk::MetaDataDictionary> tags(size[2]);
    std::vector<itk::MetaDataDictionary*> tagPointers;
    for (unsigned k = 0; k < size[2]; ++k) {
      auto& d = tags[k];
      std::ostringstream position, pixel;
      position << origin[0] << "\\" << origin[1] << "\\" << origin[2] + k * spacing[2];
      pixel << spacing[1] << "\\" << spacing[0];
      itk::EncapsulateMetaData<std::string>(d, "0020|0032", position.str());
      itk::EncapsulateMetaData<std::string>(d, "0020|0037", "1\\0\\0\\0\\1\\0");
      itk::EncapsulateMetaData<std::string>(d, "0028|0030", pixel.str());
      itk::EncapsulateMetaData<std::string>(d, "0018|0050", std::to_string(spacing[2]));
      itk::EncapsulateMetaData<std::string>(d, "0020|0013", std::to_string(k + 1));
      itk::EncapsulateMetaData<std::string>(d, "0008|0060", "MR");
      itk::EncapsulateMetaData<std::string>(d, "0020|000e", "1.2.826.0.1.3680043.2.1125.1.99");
      tagPointers.push_back(&d);
    }
    auto gdcm = itk::GDCMImageIO::New();
    gdcm->KeepOriginalUIDOn();
    auto writer = itk::ImageSeriesWriter<Volume, Slice>::New();
    writer->SetInput(volume);
    writer->SetImageIO(gdcm);
    writer->SetFileNames(names->GetFileNames());
    writer->SetMetaDataDictionaryArray(&tagPointers);
    writer->Update();
    const Image3D back = io().readImage(series);
    QCOMPARE(back.geometry().size, im.geometry().size);
    QVERIFY(std::abs(back.geometry().spacing[2] - 5.0) < 1e-3);
    QCOMPARE(back.at(5, 6, 4), im.at(5, 6, 4));
  }

  void refusesBadFiles() {
    expectRefusal(io(), path("missing.nii.gz"), "no such file");
    // Truncated: half of a valid compressed file.
    io().writeImage(path("whole.nii.gz"), ellipsoidImage({}));
    const auto bytes = fs::file_size(path("whole.nii.gz"));
    fs::copy_file(path("whole.nii.gz"), path("half.nii.gz"));
    fs::resize_file(path("half.nii.gz"), bytes / 2);
    expectRefusal(io(), path("half.nii.gz"), "");
    // Corrupt: not an image at all.
    std::ofstream(path("junk.nii")) << "this is not a NIfTI file, just text that is long enough to be read";
    expectRefusal(io(), path("junk.nii"), "");
    // A directory without DICOM files.
    fs::create_directories(path("empty_dir"));
    expectRefusal(io(), path("empty_dir"), "DICOM");
    // MetaImage whose ElementDataFile names nothing, or a directory (found by fuzz_image).
    const std::string header = "ObjectType = Image\nNDims = 3\nDimSize = 5 3 2\nElementType = MET_FLOAT\nCompressedData = True\n";
    std::ofstream(path("nameless.mha")) << header << "ElementDataFile = \n" << std::string(64, '\x7f');
    expectRefusal(io(), path("nameless.mha"), "ElementDataFile names no data file");
    std::ofstream(path("folder.mhd")) << header << "ElementDataFile = empty_dir\n";
    expectRefusal(io(), path("folder.mhd"), "is not a regular file");
  }

  // A .nii.gz is decompressed in one pass (libdeflate) into a temporary copy that ITK reads: every
  // gzip member is read and checked (CRC-32, length), a bad stream is refused by the file's name,
  // and no copy is left in the temporary directory, whatever the outcome.
  void compressedNiftiStreams() {
    const fs::path temporary = path("tmp");
    fs::create_directories(temporary);
    const QByteArray oldTmp = qgetenv("TMPDIR");
    qputenv("TMPDIR", QByteArray::fromStdString(temporary.string()));
    const Image3D im = obliqueImage();
    io().writeImage(path("plain.nii"), im);
    std::string bytes;
    {
      std::ifstream in(path("plain.nii"), std::ios::binary);
      bytes.assign(std::istreambuf_iterator<char>(in), {});
    }
    const auto gzipped = [](const std::string& data) {  // one gzip member
      z_stream z{};
      deflateInit2(&z, 6, Z_DEFLATED, 15 + 16, 8, Z_DEFAULT_STRATEGY);
      std::string out(deflateBound(&z, uLong(data.size())), '\0');
      z.next_in = reinterpret_cast<Bytef*>(const_cast<char*>(data.data()));
      z.avail_in = uInt(data.size());
      z.next_out = reinterpret_cast<Bytef*>(out.data());
      z.avail_out = uInt(out.size());
      deflate(&z, Z_FINISH);
      out.resize(z.total_out);
      deflateEnd(&z);
      return out;
    };
    const auto write = [&](const char* name, const std::string& data) { std::ofstream(path(name), std::ios::binary) << data; };
    const auto expectSameImage = [&](const char* name) {
      const Image3D back = io().readImage(path(name));
      expectSameSpace(im, back);
      QCOMPARE(back.voxels(), im.voxels());
    };
    write("one.nii.gz", gzipped(bytes));
    expectSameImage("one.nii.gz");
    // Two members, as concatenated gzip files are: read to the end of the second.
    const std::size_t half = bytes.size() / 2;
    write("two.nii.gz", gzipped(bytes.substr(0, half)) + gzipped(bytes.substr(half)));
    expectSameImage("two.nii.gz");
    // Not compressed at all, for all its name: read as it is (as zlib reads such a file).
    write("raw.nii.gz", bytes);
    expectSameImage("raw.nii.gz");
    // ... and cut short: measured as the uncompressed file it is, so refused by the size check
    // before ITK reads it (taken as compressed, a short one reached ITK, whose NIfTI reader can
    // leave the file open after a short read: found by fuzz_image).
    write("rawfew.nii.gz", bytes.substr(0, bytes.size() - 40));
    expectRefusal(io(), path("rawfew.nii.gz"), "header claims");
    // The stored CRC-32 wrong: the decompressed bytes are not what was compressed.
    std::string crc = gzipped(bytes);
    crc[crc.size() - 8] ^= 0x55;
    write("crc.nii.gz", crc);
    expectRefusal(io(), path("crc.nii.gz"), "corrupt");
    // The second member cut short.
    const std::string first = gzipped(bytes.substr(0, half)), second = gzipped(bytes.substr(half));
    write("short.nii.gz", first + second.substr(0, second.size() / 2));
    expectRefusal(io(), path("short.nii.gz"), "corrupt");
    // A sound stream whose voxels stop early: ITK refuses the copy, the message names the file.
    write("few.nii.gz", gzipped(bytes.substr(0, bytes.size() - 40)));
    write("few.nii", bytes.substr(0, bytes.size() - 40));  // likewise uncompressed (ITK read it, the rest zeros)
    expectRefusal(io(), path("few.nii"), "truncated");
    try {
      io().readImage(path("few.nii.gz"));
      QFAIL("accepted few.nii.gz");
    } catch (const InputError& e) {
      const QString message = e.what();
      QVERIFY2(message.contains("few.nii.gz") && !message.contains("sinew-read-"), qPrintable(message));
    }
    QVERIFY(fs::is_empty(temporary));
    // No temporary directory to copy into: ITK reads the file itself, checked all the same.
    qputenv("TMPDIR", QByteArray::fromStdString(path("nowhere").string()));
    expectSameImage("two.nii.gz");
    expectRefusal(io(), path("crc.nii.gz"), "corrupt");
    if (oldTmp.isNull()) qunsetenv("TMPDIR");
    else qputenv("TMPDIR", oldTmp);
  }

  // Compressed MetaImage data (.mha with LOCAL data, .mhd with a data file): MetaIO finds the stream
  // by CompressedDataSize, or without it inflates the whole file from its first byte. Where that
  // misses, it returned uninitialised voxels without an error, or never returned (found by
  // fuzz_image); the stream is now inflated first and must hold exactly the header's voxels.
  void compressedMetaImageData() {
    const Image3D im = obliqueImage();
    io().writeImage(path("local.mha"), im);  // compressed, CompressedDataSize stated
    QCOMPARE(io().readImage(path("local.mha")).voxels(), im.voxels());
    std::string bytes;
    {
      std::ifstream in(path("local.mha"), std::ios::binary);
      bytes.assign(std::istreambuf_iterator<char>(in), {});
    }
    const std::size_t sizeLine = bytes.find("CompressedDataSize = "), sizeEnd = bytes.find('\n', sizeLine) + 1;
    const std::size_t data = bytes.find("ElementDataFile = LOCAL\n") + 24;
    QVERIFY(sizeLine != std::string::npos && data > 24);
    const std::string header = bytes.substr(0, data), stream = bytes.substr(data);
    const auto write = [&](const char* name, const std::string& content) { std::ofstream(path(name), std::ios::binary) << content; };
    // LOCAL data without their size: MetaIO would inflate the header (ITK 5.2 returned garbage).
    write("unsized.mha", bytes.substr(0, sizeLine) + bytes.substr(sizeEnd));
    expectRefusal(io(), path("unsized.mha"), "CompressedDataSize");
    write("cut.mha", bytes.substr(0, bytes.size() - 5));
    expectRefusal(io(), path("cut.mha"), "beyond the end");
    // A size beyond any integer (not converted: that would be undefined behaviour).
    write("huge.mha", bytes.substr(0, sizeLine) + "CompressedDataSize = 1e30\n" + bytes.substr(sizeEnd));
    expectRefusal(io(), path("huge.mha"), "beyond the end");
    std::string flipped = bytes;
    flipped[data + stream.size() / 2] ^= 0x5a;
    write("flipped.mha", flipped);
    expectRefusal(io(), path("flipped.mha"), "corrupt");
    // A sound stream that holds fewer voxels than the header declares (one slice more).
    std::string taller = bytes;
    const std::size_t dims = taller.find("DimSize = 12 10 7");
    QVERIFY(dims != std::string::npos);
    taller.replace(dims, 17, "DimSize = 12 10 8");
    write("taller.mha", taller);
    expectRefusal(io(), path("taller.mha"), "fewer");
    // The stream in a data file beside the header, with and without its size: both read.
    write("beside.zraw", stream);
    std::string detached = header;
    detached.replace(detached.find("LOCAL"), 5, "beside.zraw");
    write("sized.mhd", detached);
    QCOMPARE(io().readImage(path("sized.mhd")).voxels(), im.voxels());
    const std::string unsized = detached.substr(0, sizeLine) + detached.substr(sizeEnd);
    write("unsized.mhd", unsized);
    QCOMPARE(io().readImage(path("unsized.mhd")).voxels(), im.voxels());
    // A header skip without the size: MetaIO would inflate the skipped bytes too.
    write("skipped.zraw", std::string(16, '\0') + stream);
    std::string skipped = unsized;
    skipped.replace(skipped.find("ElementDataFile = beside.zraw"), 29, "HeaderSize = 16\nElementDataFile = skipped.zraw");
    write("skipped.mhd", skipped);
    expectRefusal(io(), path("skipped.mhd"), "HeaderSize");
  }

  // Detached NRRD headers (.nhdr): read with their data file, field names case-insensitive as teem
  // reads them; a bad header is refused by name, and a read that fails after teem opened the data
  // file (corrupt gzip, a skip past the end, bad text) leaves no descriptor open (found by
  // fuzz_image: teem leaked one per bad file).
  void detachedNrrdHeaders() {
    const auto descriptors = [] {
      int n = 0;
      for (auto it = fs::directory_iterator("/proc/self/fd"); it != fs::directory_iterator(); ++it) ++n;
      return n;
    };
    std::vector<float> voxels(24);
    for (int i = 0; i < 24; ++i) voxels[i] = float(i);
    { std::ofstream(path("data.raw"), std::ios::binary).write(reinterpret_cast<const char*>(voxels.data()), 96); }
    const std::string head = "NRRD0004\n# a comment\ntype: float\ndimension: 3\nsizes: 4 3 2\nendian: little\n";
    std::ofstream(path("good.nhdr")) << head << "encoding: raw\nData File: data.raw\n";
    const Image3D image = io().readImage(path("good.nhdr"));
    QCOMPARE(image.geometry().size[0], 4);
    QCOMPARE(image.at(3, 2, 1), 23.0f);
    const int before = descriptors();
    std::ofstream(path("bad.gz"), std::ios::binary) << std::string("\x1f\x8b\x08\x00", 4) << std::string(60, 'x');
    std::ofstream(path("gzip.nhdr")) << head << "encoding: gzip\ndata file: bad.gz\n";
    expectRefusal(io(), path("gzip.nhdr"), "");
    std::ofstream(path("skip.nhdr")) << head << "encoding: raw\nbyte skip: 50\ndata file: data.raw\n";
    expectRefusal(io(), path("skip.nhdr"), "");
    std::ofstream(path("text.nhdr")) << head << "encoding: ascii\ndata file: data.raw\n";
    expectRefusal(io(), path("text.nhdr"), "");
    std::ofstream(path("named.nrrd")) << head << "encoding: raw\nbyte skip: 50\ndata file: data.raw\n";  // .nrrd, detached
    expectRefusal(io(), path("named.nrrd"), "");
    QCOMPARE(descriptors(), before);
    std::ofstream(path("unknown.nhdr")) << head << "encodng: raw\ndata file: data.raw\n";
    expectRefusal(io(), path("unknown.nhdr"), "unknown field");
    std::ofstream(path("list.nhdr")) << head << "encoding: raw\ndata file: LIST\ndata.raw\n";
    expectRefusal(io(), path("list.nhdr"), "several files");
    std::ofstream(path("none.nhdr")) << head << "encoding: raw\n";
    expectRefusal(io(), path("none.nhdr"), "without a data file");
  }

  void refusesHugeHeadersBeforeAllocating() {
    // A valid NIfTI header whose dimensions claim 64000^3 voxels: refused from the header alone.
    io().writeImage(path("small.nii"), obliqueImage());
    std::fstream f(path("small.nii"), std::ios::in | std::ios::out | std::ios::binary);
    const std::int16_t dims[4] = {3, 32000, 32000, 32000};
    f.seekp(40);  // dim[0..3]
    f.write(reinterpret_cast<const char*>(dims), sizeof dims);
    f.close();
    expectRefusal(io(), path("small.nii"), "2^31");
  }

  // A NIfTI file whose qform and sform disagree (both codes 2, NIFTI_XFORM_ALIGNED_ANAT, as in the
  // mricron-data atlases): the sform places it, as in FSL and nibabel, where ITK 5.2 alone takes
  // the qform; a sform with a shear leaves ITK's placement.
  void sformWinsOverADisagreeingQform() {
    const Image3D im = obliqueImage();
    io().writeImage(path("forms.nii"), im);
    std::fstream f(path("forms.nii"), std::ios::in | std::ios::out | std::ios::binary);
    const std::int16_t codes[2] = {2, 2};  // qform_code, sform_code
    const float qfac = -1.0f, quaternion[6] = {0.0f, 0.0f, 0.0f, 5.0f, -7.0f, 11.0f};  // b, c, d, qoffset x, y, z
    f.seekp(76);
    f.write(reinterpret_cast<const char*>(&qfac), sizeof qfac);
    f.seekp(252);
    f.write(reinterpret_cast<const char*>(codes), sizeof codes);
    f.write(reinterpret_cast<const char*>(quaternion), sizeof quaternion);
    f.close();
    using ItkImage = itk::Image<float, 3>;
    const auto itkPlaced = [&](const char* name) {
      auto reader = itk::ImageFileReader<ItkImage>::New();
      reader->SetFileName(path(name).string());
      reader->UpdateOutputInformation();
      return Eigen::Vector3d(reader->GetOutput()->GetOrigin()[0], reader->GetOutput()->GetOrigin()[1],
                             reader->GetOutput()->GetOrigin()[2]);
    };
    // The premise: ITK alone places it by the qform (origin (-5, 7, 11) in LPS).
    QVERIFY2((itkPlaced("forms.nii") - Eigen::Vector3d(-5.0, 7.0, 11.0)).norm() < 1e-4, "ITK took the sform itself");
    expectSameSpace(im, io().readImage(path("forms.nii")));

    // A sheared sform: not a placement ITK can hold, so the qform's stays.
    f.open(path("forms.nii"), std::ios::in | std::ios::out | std::ios::binary);
    float srowX[4];
    f.seekg(280);
    f.read(reinterpret_cast<char*>(srowX), sizeof srowX);
    srowX[1] += 0.5f;  // x also grows with j
    f.seekp(280);
    f.write(reinterpret_cast<const char*>(srowX), sizeof srowX);
    f.close();
    QVERIFY((io().readImage(path("forms.nii")).geometry().origin - itkPlaced("forms.nii")).norm() < 1e-4);
  }

  // The JHU white-matter atlas of mricron-data: its qform flips z, its sform (MNI space, as ch2's)
  // does not. Read by its sform it lies where ch2's brain is.
  void mricronAtlasesLieInMniSpace() {
    const fs::path jhu = "/usr/share/mricron/templates/JHU-WhiteMatter-labels-1mm.nii.gz";
    if (!fs::exists(jhu)) QSKIP("mricron-data is not installed");
    const LabelVolume labels = io().readLabels(jhu);
    QVERIFY((labels.geometry().origin - Eigen::Vector3d(91.0, 126.0, -72.0)).norm() < 1e-4);
    QVERIFY((labels.geometry().direction - Eigen::Vector3d(-1.0, -1.0, 1.0).asDiagonal().toDenseMatrix()).norm() < 1e-6);
    // The genu of the corpus callosum (label 3): in front of the origin, above it, on the midline.
    Eigen::Vector3d sum = Eigen::Vector3d::Zero();
    int count = 0;
    const auto& g = labels.geometry();
    for (int k = 0; k < g.size[2]; ++k)
      for (int j = 0; j < g.size[1]; ++j)
        for (int i = 0; i < g.size[0]; ++i)
          if (labels.at(i, j, k) == 3) sum += labels.indexToWorld(Vec3(float(i), float(j), float(k))).cast<double>(), ++count;
    QVERIFY(count > 1000);
    const Eigen::Vector3d centre = sum / count;  // LPS: anterior is -y
    QVERIFY2(std::abs(centre.x()) < 5.0 && centre.y() < -10.0 && centre.z() > 0.0,
             qPrintable(QString("genu at %1 %2 %3").arg(centre.x()).arg(centre.y()).arg(centre.z())));
  }

  void refusesTwoDimensionalImages() {
    ImageGeometry g;
    g.size = {8, 8, 1};
    io().writeImage(path("flat.nii"), Image3D(g, 1.0f));
    std::fstream f(path("flat.nii"), std::ios::in | std::ios::out | std::ios::binary);
    const std::int16_t dim0 = 2;
    f.seekp(40);
    f.write(reinterpret_cast<const char*>(&dim0), sizeof dim0);
    f.close();
    expectRefusal(io(), path("flat.nii"), "2D");
  }
};

QTEST_GUILESS_MAIN(TestImageIO)
#include "tst_image_io.moc"
