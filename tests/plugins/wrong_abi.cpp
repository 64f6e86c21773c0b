// A plugin built against another plugin ABI: the loader must refuse it before reading its info.
#include "sinew/core/plugin_api.h"

extern "C" __attribute__((visibility("default"))) int sinew_plugin_abi_version() { return SINEW_PLUGIN_ABI_VERSION + 1; }
extern "C" __attribute__((visibility("default"))) const sinew::PluginInfo* sinew_plugin_info() { return nullptr; }
