// Reading untrusted mesh files in a child process (docs/reliability.md). VTK's readers crash on
// some corrupt files (found by fuzz_mesh: the legacy .vtk reader, the XML reader's compressed
// blocks); a crash, a runaway allocation or a hang then ends the child, and the caller gets an
// InputError naming the file, not a dead workstation.
#pragma once

#include "sinew/core/triangle_mesh.h"

#include <filesystem>
#include <functional>
#include <shared_mutex>

namespace sinew {

// Held shared by every VTK call of the plugin, exclusively by the fork below: no other thread is
// inside VTK (holding one of its locks) when the child is made.
std::shared_mutex& vtkWorkMutex();

// Runs read() in a child process and returns its mesh. The child has a memory budget (a quarter of
// the machine's memory) and 120 s; a reader that throws InputError in the child throws it here.
// Throws InputError naming the file when the child crashes, runs out of its budget or time.
TriangleMesh readIsolated(const std::filesystem::path& path, const std::function<TriangleMesh()>& read);

}  // namespace sinew
