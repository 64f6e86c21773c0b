// Plugin loading: built-ins through the same path as run-time plugins, the search path, the ABI
// check, broken plugins reported while the others load, scene-driven loading in sinew-run.
#include "builtin_plugins.h"
#include "sinew/core/plugin_loader.h"
#include "sinew/core/scene.h"

#include <QProcess>
#include <QTemporaryDir>
#include <QtTest>

#include <fstream>

using namespace sinew;
namespace fs = std::filesystem;

namespace {
const fs::path kPluginDir = SINEW_TEST_PLUGIN_DIR;

const PluginFailure* failureFor(const PluginLoader& loader, const std::string& pluginName) {
  for (const auto& f : loader.failures())
    if (f.file.filename() == PluginLoader::fileNameFor(pluginName)) return &f;
  return nullptr;
}

struct Run {
  int code;
  QString out, err;
};
Run runSinew(const QStringList& args, const QString& pluginPath) {
  QProcess p;
  QProcessEnvironment env = QProcessEnvironment::systemEnvironment();
  env.insert("SINEW_PLUGIN_PATH", pluginPath);
  env.insert("XDG_DATA_HOME", QDir::tempPath() + "/sinew-tst-plugins-empty");  // no user plugins
  p.setProcessEnvironment(env);
  p.start(SINEW_RUN, args);
  p.waitForFinished(120000);
  return {p.exitCode(), QString::fromUtf8(p.readAllStandardOutput()), QString::fromUtf8(p.readAllStandardError())};
}
}  // namespace

class TestPlugins : public QObject {
  Q_OBJECT
private Q_SLOTS:
  void builtinsComeThroughTheLoader() {
    Registry registry;
    PluginLoader loader(registry);
    addBuiltinPlugins(loader);
    QCOMPARE(loader.plugins().size(), std::size_t(12));
    for (const PluginRecord& p : loader.plugins()) {
      QVERIFY(p.file.empty());
      QCOMPARE(p.components.size(), std::size_t(1));
      QVERIFY2(p.components[0].kind == p.kind, p.components[0].name.c_str());
    }
    QCOMPARE(loader.find("damped_verlet")->kind, PluginKind::Integrator);
    QCOMPARE(loader.find("image_io_itk")->kind, PluginKind::ImageIO);
    QCOMPARE(registry.force("smoothing").params[0].name, std::string("weight"));
  }

  void searchPathOrder() {
    qputenv("SINEW_PLUGIN_PATH", "/a:/b");
    qputenv("XDG_DATA_HOME", "/data");
    const auto dirs = PluginLoader::defaultSearchPath();
    qunsetenv("SINEW_PLUGIN_PATH");
    qunsetenv("XDG_DATA_HOME");
    QVERIFY(dirs.size() >= 3);
    QCOMPARE(dirs[0], fs::path("/a"));
    QCOMPARE(dirs[1], fs::path("/b"));
    QCOMPARE(dirs[2], fs::path("/data/sinew/plugins"));
    if (dirs.size() > 3) QCOMPARE(dirs[3].filename(), fs::path("plugins"));  // beside libsinew_core
  }

  void brokenPluginsAreReportedAndTheOthersLoad() {
    QTemporaryDir extra;
    std::ofstream(fs::path(extra.path().toStdString()) / "sinew-plugin-garbage.so") << "not a shared library\n";
    Registry registry;
    PluginLoader loader(registry);
    addBuiltinForces(loader);
    loader.setSearchPath({kPluginDir, extra.path().toStdString()});
    loader.loadAll();

    const PluginRecord* good = loader.find("test_constant");
    QVERIFY(good);
    QCOMPARE(good->version, std::string("2.5.0"));
    QCOMPARE(good->file, kPluginDir / "sinew-plugin-test_constant.so");
    QCOMPARE(good->components, (std::vector<PluginComponent>{{PluginKind::Force, "test_constant"}}));
    QCOMPARE(registry.force("test_constant").params[1].name, std::string("value"));
    QCOMPARE(loader.failures().size(), std::size_t(5));

    const PluginFailure* abi = failureFor(loader, "test_wrong_abi");
    QVERIFY(abi);
    const std::string expected = "plugin 'test_wrong_abi' was built for Sinew plugin ABI " +
                                 std::to_string(SINEW_PLUGIN_ABI_VERSION + 1) + ", but this Sinew provides ABI " +
                                 std::to_string(SINEW_PLUGIN_ABI_VERSION);
    QVERIFY2(abi->message.find(expected) != std::string::npos, abi->message.c_str());
    const PluginFailure* kind = failureFor(loader, "test_wrong_kind");
    QVERIFY(kind && kind->message.find("declares kind integrator but registered a force") != std::string::npos);
    const PluginFailure* threw = failureFor(loader, "test_throws");
    QVERIFY(threw && threw->message.find("registration failed: the plugin's data file is missing") != std::string::npos);
    const PluginFailure* dup = failureFor(loader, "test_duplicate");
    QVERIFY(dup && dup->message.find("force 'smoothing' is already registered") != std::string::npos);
    const PluginFailure* garbage = failureFor(loader, "garbage");
    QVERIFY(garbage && garbage->message.find("cannot be loaded") != std::string::npos);
    QVERIFY2(garbage->message.find("sinew-plugin-garbage.so") != std::string::npos, garbage->message.c_str());

    // A refused plugin leaves nothing behind, even what it registered before failing.
    for (const char* name : {"test_wrong_kind", "test_throws"}) {
      bool present = false;
      for (const auto& f : registry.forces()) present |= f.name == name;
      QVERIFY2(!present, name);
    }
    QCOMPARE(registry.forces().size(), std::size_t(9));  // 8 built in + test_constant
  }

  // Of the files of one name, the first on the search path is the plugin even when it is refused
  // (loadAll must not pick a different file than load(name) would); a built-in's name is refused.
  void firstFileOfANameIsThePlugin() {
    QTemporaryDir first, clash;
    fs::copy_file(kPluginDir / "sinew-plugin-test_wrong_abi.so",
                  fs::path(first.path().toStdString()) / "sinew-plugin-test_constant.so");
    fs::copy_file(kPluginDir / "sinew-plugin-test_constant.so", fs::path(clash.path().toStdString()) / "sinew-plugin-smoothing.so");
    Registry registry;
    PluginLoader loader(registry);
    addBuiltinForces(loader);
    loader.setSearchPath({first.path().toStdString(), clash.path().toStdString(), kPluginDir});
    loader.loadAll();
    QVERIFY(!loader.find("test_constant"));
    const PluginFailure* refused = failureFor(loader, "test_constant");
    QVERIFY(refused && refused->file.parent_path() == fs::path(first.path().toStdString()));
    const PluginFailure* builtin = failureFor(loader, "smoothing");
    QVERIFY(builtin && builtin->message.find("has the name of a built-in plugin") != std::string::npos);
    try {
      PluginLoader again(registry);
      again.setSearchPath(loader.searchPath());
      again.load("test_constant");
      QFAIL("load() took a later file");
    } catch (const InputError& e) {
      QVERIFY2(std::string(e.what()).find("ABI") != std::string::npos, e.what());
    }
  }

  void loadByName() {
    Registry registry;
    PluginLoader loader(registry);
    loader.setSearchPath({"/nonexistent", kPluginDir});
    QCOMPARE(loader.load("test_constant").file, kPluginDir / "sinew-plugin-test_constant.so");
    QCOMPARE(&loader.load("test_constant"), &loader.plugins()[0]);  // loading again is a no-op
    try {
      loader.load("nowhere");
      QFAIL("a missing plugin was loaded");
    } catch (const InputError& e) {
      QVERIFY2(std::string(e.what()).find("plugin 'nowhere' not found: no sinew-plugin-nowhere.so in /nonexistent") !=
                   std::string::npos,
               e.what());
    }
    QVERIFY_THROWS_EXCEPTION(InputError, loader.load("test_wrong_abi"));
    QCOMPARE(loader.plugins().size(), std::size_t(1));
  }

  void sceneNamesItsPlugins() {
    const SceneDesc s = parseScene(R"({"version": 1, "plugins": ["balloon", "test_constant"], "images": {"target": "t.nii"},
      "structures": [{"name": "a", "label": 1, "reference": {"mesh": "a.vtp"}}], "forces": {}, "schedule": [{"iterations": 1}]})",
                                   "/tmp/s.json");
    QCOMPARE(s.plugins, (std::vector<std::string>{"balloon", "test_constant"}));
    QVERIFY(sceneToJson(s).find("\"plugins\"") != std::string::npos);
    try {
      parseScene(R"({"version": 1, "plugins": ["../evil"], "images": {"target": "t.nii"},
        "structures": [{"name": "a", "label": 1, "reference": {"mesh": "a.vtp"}}], "forces": {}, "schedule": [{"iterations": 1}]})",
                 "/tmp/s.json");
      QFAIL("a path was accepted as a plugin name");
    } catch (const InputError& e) {
      QVERIFY2(std::string(e.what()).starts_with("/tmp/s.json: /plugins/0: '../evil' is not a plugin name"), e.what());
    }
  }

  void sinewRunListsPluginsWithParameters() {
    const Run r = runSinew({"--list-plugins"}, QString::fromStdString(kPluginDir.string()));
    QCOMPARE(r.code, 0);
    QVERIFY2(r.out.contains("plugin test_constant 2.5.0 (force, " + QString::fromStdString(kPluginDir.string())), qPrintable(r.out));
    QVERIFY(r.out.contains(QRegularExpression("\\n\\s+value\\s+default 1\\s+\\[0, 10\\] mm\\s+push along \\+x")));
    QVERIFY(r.out.contains("plugin damped_verlet 0.1.0 (integrator, built in)"));
    QVERIFY(r.out.contains("plugin navigate") == false);  // tools are the workstation's, not built into sinew-run
    QVERIFY(r.out.contains("not loaded: " + QString::fromStdString((kPluginDir / "sinew-plugin-test_wrong_abi.so").string())));
  }

  void sinewRunRefusesAMissingScenePlugin() {
    QTemporaryDir dir;
    const QString scene = dir.filePath("scene.json");
    std::ofstream(scene.toStdString()) << R"({"version": 1, "plugins": ["absent"], "images": {"target": "t.nii"},
      "structures": [{"name": "a", "label": 1, "reference": {"mesh": "a.vtp"}}], "forces": {}, "schedule": [{"iterations": 1}]})";
    const Run r = runSinew({scene, "-o", dir.filePath("out"), "-q"}, QString::fromStdString(kPluginDir.string()));
    QCOMPARE(r.code, 3);
    QVERIFY2(r.err.contains(scene + ": /plugins/0: plugin 'absent' not found"), qPrintable(r.err));
    QVERIFY(!QFileInfo::exists(dir.filePath("out")));
  }
};

QTEST_GUILESS_MAIN(TestPlugins)
#include "tst_plugins.moc"
