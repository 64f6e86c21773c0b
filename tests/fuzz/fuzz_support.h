// Shared by the fuzz harnesses (docs/reliability.md): the registry with the built-in IO plugins,
// and a per-process scratch folder where a harness writes its input as a file, since the readers
// take paths, as they do in sinew-run.
#pragma once

#include "sinew/core/registry.h"

#include <cstddef>
#include <cstdint>
#include <filesystem>
#include <string>

namespace sinew::fuzz {

// Every built-in plugin, registered once.
const Registry& registry();
// A folder of this process's own, removed at exit (unless SINEW_FUZZ_KEEP_SCRATCH is set).
const std::filesystem::path& scratch();
// Writes bytes to scratch()/name, replacing what was there.
std::filesystem::path writeFile(const std::string& name, const std::uint8_t* data, std::size_t size);

}  // namespace sinew::fuzz
