// SPDX-License-Identifier: MIT
// somm — the one place files are read and written (docs/hardening.md): regular files only, with a size cap;
// outputs written to a unique temporary file in the target directory (O_EXCL, never following symlinks),
// fsynced and renamed into place; multi-file outputs staged in a temporary directory; names from files escaped
// for messages. C++17.
#pragma once

#include <cstddef>
#include <cstdint>
#include <string>
#include <utility>
#include <vector>

#include "somm/result.h"

namespace somm {

// Reads a whole regular file of at most maxBytes bytes. Opens without blocking (a FIFO never hangs) and refuses
// anything but a regular file. `kind` names the kind of file in messages ("image", "glTF buffer", ...);
// `limitName` is the limit that raises the cap (see limits.h). Errors: "<path>: <problem>", IoError or
// LimitExceeded.
Result<std::vector<uint8_t>> readRegularFile(const std::string& path, uint64_t maxBytes, const char* kind,
                                             const char* limitName);

// The checks of readRegularFile without the read: the open file descriptor (blocking, close-on-exec; the caller
// closes it) and the size fstat reported — read at most that many bytes (a growing file is cut there).
struct OpenedFile {
  int fd = -1;
  uint64_t size = 0;
};
Result<OpenedFile> openRegularFile(const std::string& path, uint64_t maxBytes, const char* kind,
                                   const char* limitName);

// Writes bytes to path atomically (see above). Refuses an output that exists and is not a regular file (a FIFO,
// a device, a directory); a symlink at path is replaced, its target never written. On failure nothing is left
// behind and an existing path is untouched.
Status writeFileAtomically(const std::string& path, const uint8_t* bytes, size_t size);
// The same, of the concatenation of `count` byte ranges {data, size} (written in order, never copied).
Status writeFileAtomically(const std::string& path, const std::pair<const uint8_t*, size_t>* pieces,
                           size_t count);

// InvalidArgument when `output` names the same file as one of `inputs` (same device and inode, or the same
// path when it does not exist yet) or exists and is not a regular file. Call before reading the inputs.
Status checkOutputPath(const std::string& output, const std::vector<std::string>& inputs);

// A directory written whole or not at all: files are written into a fresh temporary directory next to `path`,
// commit() renames it into place. `path` must not exist or be an empty directory (a non-empty one is refused,
// its files kept). The destructor removes the temporary directory unless committed.
class StagedDirectory {
 public:
  StagedDirectory() = default;
  StagedDirectory(const StagedDirectory&) = delete;
  StagedDirectory& operator=(const StagedDirectory&) = delete;
  ~StagedDirectory();
  Status begin(const std::string& path);
  // The temporary directory to write into (valid after begin()).
  const std::string& staging() const { return staging_; }
  Status commit();

 private:
  std::string path_, staging_;
  bool committed_ = false;
};

// Bytes from an input (a name, a path, a line) made printable: control bytes, DEL and bytes that are not valid
// UTF-8 (or are C1 controls) as \xNN; everything else unchanged. Idempotent on its own output.
std::string escapeName(const std::string& s);

}  // namespace somm
