#pragma once
// The one way gatcore writes a file: all bytes or nothing. The bytes go to
// "<path>.<pid>.<n>.tmp" in the same folder (same file system, so the rename is atomic),
// are fsync'd, renamed over `path`, and the folder is fsync'd so the rename
// itself survives a power cut. On any failure (full disk, no permission, a
// short write) the temp file is removed and InvalidArgument names `path` and
// the reason; `path` keeps its old contents. A temp file left behind by a
// process killed mid-write (its pid is gone) is removed by the next write.
#include <string>
#include <string_view>

namespace gatcore {

void write_file_atomic(const std::string& path, std::string_view bytes);

}  // namespace gatcore
