// Crash recovery for the workstation (docs/workstation.md, "Work that survives"): the session is
// saved to a recovery folder of its own while the user works, and a workstation that starts after
// one that died (kill -9, a crash, a power cut) offers to restore it. No Qt here: the window drives
// it with a timer.
//
// The folder (format 1): session.json (the scene, where the schedule stands, the timeline, and the
// ids of the current state and of every undo and redo step) and one snapshot-ID.bin per snapshot,
// each ending in its CRC-32. Snapshots never change, so each is written once; session.json is
// replaced last, by a rename, and files it no longer names are removed after it: whenever the
// process dies, the folder holds one whole, consistent save. The folder is held by an flock on its
// .lock file while its workstation lives, so a slot nobody holds belongs to a workstation that died.
#pragma once

#include "segmentation_session.h"

#include <atomic>
#include <filesystem>
#include <future>
#include <mutex>
#include <string>
#include <vector>

namespace sinew {

class SessionRecovery {
public:
  // root: where every workstation's slot lies (e.g. ~/.local/share/Sinew/recovery); this one
  // takes root/<pid>, created and locked here. Throws InputError naming the folder when it cannot.
  explicit SessionRecovery(const std::filesystem::path& root);
  // Waits for a save in progress and removes the slot: a workstation that closes normally leaves
  // nothing to recover.
  ~SessionRecovery();
  SessionRecovery(const SessionRecovery&) = delete;
  SessionRecovery& operator=(const SessionRecovery&) = delete;

  const std::filesystem::path& folder() const { return folder_; }
  // Saves when the session changed since the last save and at least intervalSeconds have passed
  // since it. The state is copied here (the undo steps are shared, not copied); the files are
  // written on a background thread. Returns true when a save started.
  bool maybeSave(SegmentationSession& session, double intervalSeconds);
  // Saves now and waits for the files (throws InputError when they cannot be written).
  void saveNow(SegmentationSession& session);
  // The session was closed: nothing to recover any more.
  void clear();
  // Waits for the save in progress; rethrows its failure.
  void wait();

  int savesCompleted() const { return completed_; }
  double lastCopySeconds() const { return copySeconds_; }    // on the caller's thread
  double maxCopySeconds() const { return maxCopySeconds_; }
  std::string lastError() const;

  // Slots under root that no living workstation holds, with a complete save, newest first.
  static std::vector<std::filesystem::path> orphans(const std::filesystem::path& root);
  // Reads a slot; throws InputError naming the file and the problem.
  static SessionState read(const std::filesystem::path& folder);
  // Removes a slot nobody holds (after restoring it, or when the user declines).
  static void discard(const std::filesystem::path& folder);

private:
  void start(SegmentationSession& session);
  void write(const SessionState& state);

  std::filesystem::path folder_;
  int lockFd_ = -1;
  std::future<void> pending_;
  std::uint64_t savedRevision_ = 0;
  double lastSave_ = -1e30;  // seconds on a steady clock
  std::atomic<int> completed_{0};
  double copySeconds_ = 0.0, maxCopySeconds_ = 0.0;
  mutable std::mutex errorMutex_;
  std::string error_;
};

}  // namespace sinew
