#include "synthetic.h"

namespace sinew::testing {

const Registry& builtinRegistry() {
  static const Registry registry = [] {
    Registry r;
    registerBuiltinPlugins(r);
    return r;
  }();
  return registry;
}

}  // namespace sinew::testing
