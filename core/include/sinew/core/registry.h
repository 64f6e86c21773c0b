// The registry of plugins. Every component is registered explicitly by one function (no static
// initialisers); the descriptor carries the parameter declarations, so scene files, CLI, GUI and
// docs all read the same list.
#pragma once

#include "sinew/core/force.h"
#include "sinew/core/io.h"
#include "sinew/core/plugin_api.h"

#include <functional>
#include <memory>
#include <string>
#include <string_view>
#include <vector>

namespace sinew {

struct ForceDescriptor {
  std::string name;
  std::string summary;
  std::vector<ParamDecl> params;  // "weight" is prepended by the registry
  std::function<std::unique_ptr<Force>()> create;
};

struct IntegratorDescriptor {
  std::string name;
  std::string summary;
  std::vector<ParamDecl> params;
  std::function<std::unique_ptr<Integrator>()> create;
};

class Registry {
public:
  void addForce(ForceDescriptor d);
  void addIntegrator(IntegratorDescriptor d);
  // Throw InputError naming the unknown component and listing the known ones.
  const ForceDescriptor& force(std::string_view name) const;
  const IntegratorDescriptor& integrator(std::string_view name) const;
  const std::vector<ForceDescriptor>& forces() const { return forces_; }
  const std::vector<IntegratorDescriptor>& integrators() const { return integrators_; }

  void addImageIO(ImageIODescriptor d);
  void addMeshIO(MeshIODescriptor d);
  // The plugin that handles this path's extension; throws InputError naming the file otherwise.
  const ImageIODescriptor& imageIOFor(const std::filesystem::path& path) const;
  const MeshIODescriptor& meshIOFor(const std::filesystem::path& path) const;
  // A mesh IO plugin that can build surfaces from labels; throws InputError when none is loaded.
  const MeshIODescriptor& labelSurfaceBuilder() const;
  // The image plugin that registers images and reads/writes transforms; throws InputError when
  // none is loaded.
  const ImageIODescriptor& imageRegistration() const;
  // A mesh IO plugin that reads files exactly as stored (model files), for this path.
  const MeshIODescriptor& exactMeshReaderFor(const std::filesystem::path& path) const;
  const std::vector<ImageIODescriptor>& imageIOs() const { return imageIOs_; }
  const std::vector<MeshIODescriptor>& meshIOs() const { return meshIOs_; }

  // Moves every component of `other` into this registry. Throws InputError naming the first name
  // already taken, before anything is moved.
  void merge(Registry&& other);
  // Every component, forces first, each kind in registration order.
  std::vector<PluginComponent> components() const;
  bool empty() const { return forces_.empty() && integrators_.empty() && imageIOs_.empty() && meshIOs_.empty(); }

private:
  std::vector<ForceDescriptor> forces_;
  std::vector<IntegratorDescriptor> integrators_;
  std::vector<ImageIODescriptor> imageIOs_;
  std::vector<MeshIODescriptor> meshIOs_;
};

}  // namespace sinew
