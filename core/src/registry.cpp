#include "sinew/core/registry.h"

#include <algorithm>
#include <sstream>

namespace sinew {

const ImageIODescriptor& Registry::imageRegistration() const {
  for (const auto& d : imageIOs_)
    if (d.registerImages && d.readTransform && d.writeTransform) return d;
  throw InputError("no loaded image plugin can register images or read transforms");
}

const MeshIODescriptor& Registry::exactMeshReaderFor(const std::filesystem::path& path) const {
  const MeshIODescriptor& d = meshIOFor(path);
  if (!d.readExact) throw InputError(path.string() + ": mesh plugin '" + d.name + "' cannot read model files");
  return d;
}

namespace {
template <class D>
const D& find(const std::vector<D>& list, std::string_view name, const char* kind) {
  for (const D& d : list)
    if (d.name == name) return d;
  std::ostringstream m;
  m << "unknown " << kind << " '" << name << "' (available:";
  for (const D& d : list) m << ' ' << d.name;
  m << ')';
  throw InputError(m.str());
}

template <class D>
void checkUnique(const std::vector<D>& list, const std::string& name) {
  for (const D& d : list)
    if (d.name == name) throw std::logic_error("plugin registered twice: " + name);
}
}  // namespace

void Registry::addForce(ForceDescriptor d) {
  checkUnique(forces_, d.name);
  d.params.insert(d.params.begin(), weightParam());
  forces_.push_back(std::move(d));
}

void Registry::addIntegrator(IntegratorDescriptor d) {
  checkUnique(integrators_, d.name);
  integrators_.push_back(std::move(d));
}

const ForceDescriptor& Registry::force(std::string_view name) const { return find(forces_, name, "force"); }

const IntegratorDescriptor& Registry::integrator(std::string_view name) const {
  return find(integrators_, name, "integrator");
}

void Registry::addImageIO(ImageIODescriptor d) {
  checkUnique(imageIOs_, d.name);
  imageIOs_.push_back(std::move(d));
}

void Registry::addMeshIO(MeshIODescriptor d) {
  checkUnique(meshIOs_, d.name);
  meshIOs_.push_back(std::move(d));
}

namespace {
template <class D>
const D& byExtension(const std::vector<D>& list, const std::filesystem::path& path, const char* what) {
  const std::string ext = ioExtension(path);
  for (const D& d : list)
    if (std::find(d.extensions.begin(), d.extensions.end(), ext) != d.extensions.end()) return d;
  std::ostringstream m;
  m << path.string() << ": no " << what << " plugin reads '" << (ext.empty() ? "(no extension)" : ext)
    << "' files (supported:";
  for (const D& d : list)
    for (const auto& e : d.extensions) m << ' ' << (e == "/" ? "DICOM-directory" : e);
  m << ')';
  throw InputError(m.str());
}
}  // namespace

const ImageIODescriptor& Registry::imageIOFor(const std::filesystem::path& path) const {
  return byExtension(imageIOs_, path, "image IO");
}

const MeshIODescriptor& Registry::meshIOFor(const std::filesystem::path& path) const {
  return byExtension(meshIOs_, path, "mesh IO");
}

const MeshIODescriptor& Registry::labelSurfaceBuilder() const {
  for (const auto& d : meshIOs_)
    if (d.labelSurface) return d;
  throw InputError("no loaded mesh IO plugin can build a surface from a label map");
}

namespace {
template <class D>
void checkFree(const std::vector<D>& mine, const std::vector<D>& theirs, const char* kind) {
  for (const D& t : theirs)
    for (const D& m : mine)
      if (m.name == t.name) throw InputError(std::string(kind) + " '" + t.name + "' is already registered");
}
template <class D>
void moveAll(std::vector<D>& mine, std::vector<D>& theirs) {
  for (D& d : theirs) mine.push_back(std::move(d));
  theirs.clear();
}
}  // namespace

void Registry::merge(Registry&& other) {
  checkFree(forces_, other.forces_, "force");
  checkFree(integrators_, other.integrators_, "integrator");
  checkFree(imageIOs_, other.imageIOs_, "image IO");
  checkFree(meshIOs_, other.meshIOs_, "mesh IO");
  moveAll(forces_, other.forces_);  // the weight parameter was prepended when they were added
  moveAll(integrators_, other.integrators_);
  moveAll(imageIOs_, other.imageIOs_);
  moveAll(meshIOs_, other.meshIOs_);
}

std::vector<PluginComponent> Registry::components() const {
  std::vector<PluginComponent> all;
  for (const auto& d : forces_) all.push_back({PluginKind::Force, d.name});
  for (const auto& d : integrators_) all.push_back({PluginKind::Integrator, d.name});
  for (const auto& d : imageIOs_) all.push_back({PluginKind::ImageIO, d.name});
  for (const auto& d : meshIOs_) all.push_back({PluginKind::MeshIO, d.name});
  return all;
}

}  // namespace sinew
