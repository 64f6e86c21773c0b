// The scene parser: any text gives a SceneDesc or an InputError, nothing else. A valid scene is
// also written back and read again: what Sinew writes, it must read.
#include "sinew/core/scene.h"
#include "sinew/core/types.h"

#include <cstdint>
#include <string>

extern "C" int LLVMFuzzerTestOneInput(const std::uint8_t* data, std::size_t size) {
  const std::string text(reinterpret_cast<const char*>(data), size);
  sinew::SceneDesc scene;
  try {
    scene = sinew::parseScene(text, "/fuzz/scene.json");
  } catch (const sinew::InputError&) {
    return 0;
  }
  const sinew::SceneDesc again = sinew::parseScene(sinew::sceneToJson(scene), "/fuzz/scene.json");
  if (sinew::sceneToJson(again) != sinew::sceneToJson(scene)) __builtin_trap();
  return 0;
}
