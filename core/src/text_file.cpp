#include "text_file.hpp"

#include <algorithm>
#include <cerrno>
#include <charconv>
#include <cmath>
#include <cstdio>
#include <cstring>

#include <sys/stat.h>

namespace gm::text {

std::string quote(std::string_view t) {
  std::string s = "'";
  const std::size_t n = std::min<std::size_t>(t.size(), 32);
  for (std::size_t i = 0; i < n; ++i) {
    const unsigned char c = static_cast<unsigned char>(t[i]);
    if (c >= 0x20 && c < 0x7f) {
      s += static_cast<char>(c);
    } else {
      char buf[8];
      std::snprintf(buf, sizeof buf, "\\x%02X", c);
      s += buf;
    }
  }
  if (t.size() > n) s += "...";
  return s + "'";
}

std::string format_number(double v) {
  char buf[32];
  std::snprintf(buf, sizeof buf, "%.9g", v);
  return buf;
}

bool to_double(std::string_view t, double& v, std::string& why) {
  if (t.size() > 1 && t[0] == '+' && t[1] != '-' && t[1] != '+') t.remove_prefix(1);
  const char* end = t.data() + t.size();
  const auto r = std::from_chars(t.data(), end, v, std::chars_format::general);
  if (r.ec == std::errc::result_out_of_range) {
    why = "is out of the range of a double";
    return false;
  }
  if (r.ec != std::errc() || r.ptr != end) {
    why = "is not a number";
    return false;
  }
  if (!std::isfinite(v)) {
    why = "is not finite";
    return false;
  }
  return true;
}

bool read_file(const char* path, const char* what, const char* magic, std::string& text,
               std::string& msg) {
  // a FIFO would block the open until a writer comes (forever), a directory or device is no file
  struct stat st;
  if (::stat(path, &st) == 0 && !S_ISREG(st.st_mode)) {
    msg = std::string(path) + ": not a regular file (a directory, FIFO, socket or device); allowed: the path "
          "of a readable " + what + " ('" + magic + " 1')";
    return false;
  }
  std::FILE* f = std::fopen(path, "rb");
  if (!f) {
    msg = std::string(path) + ": cannot open the " + what + ": " + std::strerror(errno) +
          "; allowed: the path of a readable " + what + " ('" + magic + " 1')";
    return false;
  }
  char buf[65536];
  bool too_big = false;
  for (;;) {
    const std::size_t n = std::fread(buf, 1, sizeof buf, f);
    text.append(buf, n);
    if (text.size() > kMaxFileBytes) {
      too_big = true;
      break;
    }
    if (n < sizeof buf) break;
  }
  const bool read_error = std::ferror(f) != 0;
  const int err = errno;
  std::fclose(f);
  if (too_big) {
    msg = std::string(path) + ": the " + what + " is larger than 64 MiB; allowed: up to 64 MiB";
    return false;
  }
  if (read_error) {
    msg = std::string(path) + ": cannot read the " + what + ": " + std::strerror(err) +
          "; allowed: a readable " + what + " ('" + magic + " 1')";
    return false;
  }
  return true;
}

TokenLines::TokenLines(std::string_view text) : text_(text) {
  if (text_.size() >= 3 && text_.substr(0, 3) == "\xEF\xBB\xBF") text_.remove_prefix(3);
}

bool TokenLines::next() {
  while (!text_.empty()) {
    ++line_;
    const std::size_t nl = text_.find('\n');
    std::string_view l = text_.substr(0, nl);
    text_.remove_prefix(nl == std::string_view::npos ? text_.size() : nl + 1);
    const std::size_t hash = l.find('#');
    if (hash != std::string_view::npos) l = l.substr(0, hash);
    tokens_.clear();
    std::size_t i = 0;
    while (i < l.size()) {
      while (i < l.size() && is_space(l[i])) ++i;
      const std::size_t b = i;
      while (i < l.size() && !is_space(l[i])) ++i;
      if (i > b) tokens_.push_back(l.substr(b, i - b));
    }
    if (!tokens_.empty()) return true;
  }
  return false;
}

}  // namespace gm::text
