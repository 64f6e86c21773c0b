// The machine-readable report of a run: report.json, report.csv (one row per structure) and
// timeline.csv (error and motion against simulation time).
#pragma once

#include "sinew/core/plugin_loader.h"
#include "sinew/core/scene_runner.h"

#include <filesystem>

namespace sinew {

// `plugins`: the loaded plugins; the run-time ones are recorded (name, version, file), so that a
// result can be traced to the plugin build that made it.
void writeReportJson(const std::filesystem::path& path, const RunReport& report, const SceneDesc& scene,
                     std::span<const PluginRecord> plugins = {});
void writeReportCsv(const std::filesystem::path& path, const RunReport& report);
void writeTimelineCsv(const std::filesystem::path& path, const RunReport& report, const SceneDesc& scene);
// error_vs_time.png: ASSD (or mean displacement without ground truth) against simulation time,
// one curve per structure, level changes marked.
void writeErrorPlot(const std::filesystem::path& path, const RunReport& report, const SceneDesc& scene);
// slices.png: three orthogonal slices through the structures with their label boundaries.
void writeSliceOverlay(const std::filesystem::path& path, const Image3D& image, const LabelVolume& labels,
                       const SceneDesc& scene);

}  // namespace sinew
