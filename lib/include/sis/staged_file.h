#pragma once
// Output files written in place of nothing until they are whole: a
// temporary file beside the target (same folder, so the rename is atomic),
// created exclusively under an unpredictable name (mkostemps: a link or file
// planted at a guessed name is never followed or overwritten), renamed onto
// the target by commit() (rename replaces the name, never a file a link at
// the target points to), removed when dropped uncommitted, on an exception
// and on the signals of remove_staged_files_on_signals().
#include <string>

namespace sis {

class StagedFile {
 public:
  // Creates the temporary file beside `target`. Throws OutputError naming
  // the target and the reason (missing or read-only folder...).
  explicit StagedFile(const std::string& target);
  ~StagedFile();  // removes the temporary file unless committed
  StagedFile(StagedFile&& other) noexcept;
  StagedFile& operator=(StagedFile&&) = delete;
  StagedFile(const StagedFile&) = delete;
  StagedFile& operator=(const StagedFile&) = delete;

  const std::string& target() const { return target_; }
  const std::string& temporary() const { return temporary_; }
  // The temporary file's descriptor, open for writing (-1 once closed).
  int fd() const { return fd_; }
  // Closes the descriptor; a failed close (a deferred write error) throws
  // OutputError.
  void close();
  // Closes if open, then renames the temporary file onto the target.
  // Throws OutputError; the target is then as it was.
  void commit();

 private:
  std::string target_, temporary_;
  int fd_ = -1;
  int slot_ = -1;  // in the registry the signal handler reads
  bool committed_ = false;
};

// Installs handlers for SIGINT, SIGTERM, SIGHUP, SIGQUIT, SIGPIPE, SIGALRM,
// SIGXCPU, SIGUSR1, SIGUSR2 and SIGVTALRM, and for the signals of a failure
// in the process (SIGABRT: an assertion or abort() in a library; SIGSEGV,
// SIGBUS, SIGFPE, SIGILL, SIGSYS; on an alternate stack for the calling
// thread), that remove every uncommitted staged file, then end the process
// by the same signal (its default action: a core dump where enabled); a
// signal that is ignored stays ignored. SIGXFSZ is ignored, so that a write past
// the file size limit fails as an error (EFBIG) and is reported. For
// programs (the tools); a library user keeps its own handlers.
void remove_staged_files_on_signals();

// While one lives (several at once, on any threads, share one install):
// the handlers of remove_staged_files_on_signals() on those of its signals
// whose action is the default one, which would end the process and leave
// the staged files; their former actions are put back when the last one
// ends. For a library user with handlers of its own around its writes (the
// Python module): a signal it handles or ignores is left to it.
class StagedFileSignals {
 public:
  StagedFileSignals();
  ~StagedFileSignals();
  StagedFileSignals(const StagedFileSignals&) = delete;
  StagedFileSignals& operator=(const StagedFileSignals&) = delete;
};

}  // namespace sis
