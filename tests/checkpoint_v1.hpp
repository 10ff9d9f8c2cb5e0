#pragma once
// A format-version-1 checkpoint of the same contents as a version-2 file's
// bytes, as older gatcore wrote it: format_version "1" and the checksum
// (FNV-1a 64) over the data section only. For test_checkpoint (gat
// upgrade-checkpoint) and the fuzz seed corpus (make_corpus).
#include <cstdint>
#include <cstdio>
#include <stdexcept>
#include <string>

namespace testutil {

inline std::string version_1_bytes(const std::string& v2) {
  if (v2.size() < 8) throw std::invalid_argument("version_1_bytes: not a checkpoint");
  std::uint64_t n = 0;
  for (int k = 0; k < 8; ++k) n |= std::uint64_t(static_cast<unsigned char>(v2[std::size_t(k)])) << (8 * k);
  std::string header = v2.substr(8, std::size_t(n));
  const std::string data = v2.substr(8 + std::size_t(n));
  std::uint64_t h = 1469598103934665603ull;
  for (unsigned char c : data) h = (h ^ c) * 1099511628211ull;
  char sum[17];
  std::snprintf(sum, sizeof sum, "%016llx", static_cast<unsigned long long>(h));
  // The header's JSON holds "format_version":"2" and "checksum":"<16 hex>" once each.
  const auto put = [&](const std::string& key, const std::string& value) {
    std::string k = "\"";  // built by appends: GCC 12 warns (-Wrestrict) on const char* + string
    k += key;
    k += "\":\"";
    const std::size_t at = header.find(k);
    if (at == std::string::npos) throw std::invalid_argument("version_1_bytes: no " + key);
    const std::size_t v = at + k.size(), end = header.find('"', v);
    header.replace(v, end - v, value);
  };
  put("format_version", "1");
  put("checksum", sum);
  while (header.size() % 8) header += ' ';
  std::string out;
  for (int k = 0; k < 8; ++k) out += char((std::uint64_t(header.size()) >> (8 * k)) & 0xff);
  return out + header + data;
}

}  // namespace testutil
