// Small helpers shared by the parsers of the project's text resources (deviation files, user
// tables): bounded file reading, locale-independent numbers, tokens quoted for messages.
#pragma once

#include <cstddef>
#include <string>
#include <string_view>
#include <vector>

namespace gm::text {

constexpr std::size_t kMaxFileBytes = 64u << 20;  // 64 MiB

// Space or tab (or the CR of a CRLF line end).
inline bool is_space(char c) { return c == ' ' || c == '\t' || c == '\r'; }

// A token as it may appear in a message: quoted, non-printable bytes escaped, at most 32 bytes.
std::string quote(std::string_view token);

// %.9g of v.
std::string format_number(double v);

// Locale-independent number: std::from_chars with an optional leading '+'. False (and a reason)
// unless the whole token is one finite number.
bool to_double(std::string_view token, double& v, std::string& why);

// The whole file into text, at most kMaxFileBytes. False with msg naming the path and saying
// what is allowed ("the path of a readable <what> ('<magic> 1')") on a missing, unreadable or
// oversized file.
bool read_file(const char* path, const char* what, const char* magic, std::string& text,
               std::string& msg);

// The token lines of a text resource, one after another: a leading UTF-8 byte-order mark is
// skipped, '\n' ends a line, '#' starts a comment that runs to the line's end, tokens are
// separated by spaces and tabs (is_space); lines without a token are skipped.
class TokenLines {
 public:
  explicit TokenLines(std::string_view text);
  // Moves to the next line with a token; false at the end of the text.
  bool next();
  int line() const { return line_; }  // 1-based number of the current line
  const std::vector<std::string_view>& tokens() const { return tokens_; }

 private:
  std::string_view text_;
  int line_ = 0;
  std::vector<std::string_view> tokens_;
};

}  // namespace gm::text
