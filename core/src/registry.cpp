#include "sinew/core/registry.h"

#include <sstream>

namespace sinew {

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

}  // namespace sinew
