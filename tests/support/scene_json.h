// Scenes and reports as Qt JSON for the tests that run Sinew's programs (header-only, Qt Test).
#pragma once

#include <QFile>
#include <QJsonArray>
#include <QJsonDocument>
#include <QJsonObject>
#include <QString>
#include <QtTest>

namespace sinew::testing {

// The file's JSON object; empty when it cannot be read.
inline QJsonObject readJson(const QString& path) {
  QFile f(path);
  if (!f.open(QIODevice::ReadOnly)) return {};
  return QJsonDocument::fromJson(f.readAll()).object();
}

inline void writeJson(const QString& path, const QJsonObject& o) {
  QFile f(path);
  QVERIFY(f.open(QIODevice::WriteOnly));
  f.write(QJsonDocument(o).toJson());
}

// Every level of the scene runs no iteration: only what comes before the steps is done.
inline void withoutIterations(QJsonObject& scene) {
  QJsonArray schedule = scene["schedule"].toArray();
  for (int i = 0; i < schedule.size(); ++i) {
    QJsonObject l = schedule[i].toObject();
    l["iterations"] = 0;
    schedule[i] = l;
  }
  scene["schedule"] = schedule;
}

}  // namespace sinew::testing
