// The registry of plugins. Every component is registered explicitly by one function (no static
// initialisers); the descriptor carries the parameter declarations, so scene files, CLI, GUI and
// docs all read the same list.
#pragma once

#include "sinew/core/force.h"

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

private:
  std::vector<ForceDescriptor> forces_;
  std::vector<IntegratorDescriptor> integrators_;
};

}  // namespace sinew
