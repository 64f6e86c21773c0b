// The programs that draw pictures without a window (sinew-run, sinew-cohort) need a QGuiApplication
// for fonts; on the offscreen platform it needs no display.
#pragma once

#include <QGuiApplication>

#include <memory>

namespace sinew {

std::unique_ptr<QGuiApplication> startOffscreenQt(char* programName);

}  // namespace sinew
