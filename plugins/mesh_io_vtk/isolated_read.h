// Reading untrusted mesh files in a child process (docs/reliability.md). VTK's readers crash on
// some corrupt files (found by fuzz_mesh: the legacy .vtk reader, the XML reader's compressed
// blocks); a crash, a runaway allocation or a hang then ends the child, and the caller gets an
// InputError naming the file, not a dead workstation.
//
// The children are reader servers, forked on demand and kept for later reads (a fork of a process
// holding ITK, VTK, Qt and images costs milliseconds; a model is 48 files). A server that crashed or
// timed out is discarded; one idle for a few seconds exits by itself, so it does not hold the
// parent's old memory; each serves a bounded number of reads.
#pragma once

#include "sinew/core/triangle_mesh.h"

#include <filesystem>
#include <shared_mutex>

namespace sinew {

// Held shared by every VTK call of the plugin, exclusively by the fork below: no other thread is
// inside VTK (holding one of its locks) when a server is made.
std::shared_mutex& vtkWorkMutex();

// A reader run in the server. A plain function: the server is a fork of this process, so the
// function's address means the same there.
using MeshReadFunction = TriangleMesh (*)(const std::filesystem::path&);

// Runs read(path) in a reader server and returns its mesh. A server has a memory budget (a quarter
// of the machine's memory) and 120 s per read; a reader that throws InputError there throws it here.
// Throws InputError naming the file when the server crashes, runs out of its budget or time.
TriangleMesh readIsolated(const std::filesystem::path& path, MeshReadFunction read);

}  // namespace sinew
