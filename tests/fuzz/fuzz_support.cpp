#include "fuzz_support.h"

#include "builtin_plugins.h"

#include <unistd.h>

#include <cstdio>
#include <cstdlib>
#include <fstream>
#include <stdexcept>

namespace sinew::fuzz {
namespace fs = std::filesystem;

const Registry& registry() {
  static const Registry r = [] {
    Registry reg;
    registerBuiltinPlugins(reg);
    return reg;
  }();
  return r;
}

namespace {
struct Scratch {
  fs::path path;
  Scratch() {
    path = fs::temp_directory_path() / ("sinew-fuzz-" + std::to_string(::getpid()));
    fs::create_directories(path);
  }
  ~Scratch() {
    if (std::getenv("SINEW_FUZZ_KEEP_SCRATCH")) return;  // to look at what a harness wrote
    std::error_code ec;
    fs::remove_all(path, ec);
  }
};
}  // namespace

const fs::path& scratch() {
  static const Scratch s;
  return s.path;
}

fs::path writeFile(const std::string& name, const std::uint8_t* data, std::size_t size) {
  const fs::path file = scratch() / name;
  std::ofstream out(file, std::ios::binary | std::ios::trunc);
  out.write(reinterpret_cast<const char*>(data), static_cast<std::streamsize>(size));
  if (!out) throw std::runtime_error("fuzz: cannot write " + file.string());
  return file;
}

}  // namespace sinew::fuzz
