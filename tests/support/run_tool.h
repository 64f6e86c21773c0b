// Runs one of Sinew's programs for a test and keeps its exit code and output (header-only: Qt's
// QProcess, which every test links through Qt Test).
#pragma once

#include <QProcess>
#include <QString>
#include <QStringList>

namespace sinew::testing {

struct ToolResult {
  int code = -1;  // -1: it crashed or did not finish
  QString err, out;
};

inline ToolResult runTool(const QString& program, const QStringList& args, int timeoutMs = 900000) {
  QProcess p;
  p.start(program, args);
  p.waitForFinished(timeoutMs);
  return {p.exitStatus() == QProcess::NormalExit ? p.exitCode() : -1, p.readAllStandardError(), p.readAllStandardOutput()};
}

}  // namespace sinew::testing
