// The main window's crash recovery: the autosave timer and the restore of a dead workstation's
// slot (session_recovery.h does the work; docs/workstation.md).
#include "main_window.h"
#include "surface_drawing.h"

#include <QDateTime>
#include <QFileInfo>
#include <QMessageBox>
#include <QProgressDialog>
#include <QStatusBar>

namespace sinew {

void MainWindow::startAutosave() {
  if (options_.recoveryRoot.empty()) return;
  try {
    recovery_ = std::make_unique<SessionRecovery>(options_.recoveryRoot);
  } catch (const std::exception& e) {
    std::fprintf(stderr, "sinew: autosave is off: %s\n", e.what());
    return;
  }
  // Checked every second; a save starts only when something changed and the interval has passed.
  autosaveTimer_.setInterval(1000);
  connect(&autosaveTimer_, &QTimer::timeout, this, &MainWindow::autosave);
  autosaveTimer_.start();
}

void MainWindow::autosave() {
  if (!recovery_) return;
  try {
    recovery_->maybeSave(session_, options_.autosaveSeconds);
  } catch (const std::exception& e) {
    if (!autosaveFailed_) statusBar()->showMessage(tr("Autosave failed: %1").arg(QString::fromUtf8(e.what())), 10000);
    autosaveFailed_ = true;
    return;
  }
  const std::string error = recovery_->lastError();
  if (!error.empty() && !autosaveFailed_) {
    statusBar()->showMessage(tr("Autosave failed: %1").arg(QString::fromStdString(error)), 10000);
    autosaveFailed_ = true;
  }
}

bool MainWindow::restoreRecovered(const QString& folder) {
  setRunning(false);
  drawing_ = makeHostDrawing();
  QProgressDialog progress(tr("Restoring the session..."), QString(), 0, 0, this);
  progress.setWindowModality(Qt::WindowModal);
  progress.setMinimumDuration(300);
  try {
    const SessionState state = SessionRecovery::read(folder.toStdString());
    session_.restoreState(state, sessionOptions(progress));
  } catch (const std::exception& e) {
    progress.close();
    if (session_.isOpen()) sessionReplaced();
    showError(tr("Restore session"), QString::fromUtf8(e.what()));
    return false;
  }
  progress.close();
  SessionRecovery::discard(folder.toStdString());
  imageOnly_.reset();
  sceneFile_ = QString::fromStdString(session_.scene().file.string());
  sessionReplaced();
  setWindowTitle(QString("Sinew - %1 (restored)").arg(QFileInfo(sceneFile_).fileName()));
  statusBar()->showMessage(tr("Restored the session Sinew was working on when it closed unexpectedly"), 10000);
  refreshViews();
  updateActions();
  updateStatus();
  return true;
}

void MainWindow::offerRecovery() {
  if (options_.recoveryRoot.empty()) return;
  const auto found = SessionRecovery::orphans(options_.recoveryRoot);
  if (found.empty()) return;
  const QString folder = QString::fromStdString(found.front().string());
  const QDateTime when = QFileInfo(folder + "/session.json").lastModified();
  const auto answer = QMessageBox::question(
      this, tr("Restore session"),
      tr("Sinew closed unexpectedly. Restore the session it saved at %1?").arg(when.toString(Qt::TextDate)),
      QMessageBox::Yes | QMessageBox::Discard, QMessageBox::Yes);
  // Declined: removed. Failed: kept for another try. Older slots wait for the next start.
  if (answer == QMessageBox::Yes) restoreRecovered(folder);
  else SessionRecovery::discard(folder.toStdString());
}

}  // namespace sinew
