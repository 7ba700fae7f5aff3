#pragma once
// ASCII text helpers shared by lexer, interpreter and writers. NC programs are ASCII; locale-free
// on purpose (std::toupper depends on the C locale and is slower on the hot path).
#include <string>
#include <string_view>

namespace postproc::gcode::text {

constexpr bool is_space(char c) { return c == ' ' || c == '\t'; }
constexpr char upper(char c) { return (c >= 'a' && c <= 'z') ? static_cast<char>(c - 32) : c; }

inline bool iequals(std::string_view a, std::string_view b) {
  if (a.size() != b.size()) return false;
  for (std::size_t i = 0; i < a.size(); ++i)
    if (upper(a[i]) != upper(b[i])) return false;
  return true;
}

/// Without the spaces and tabs around it, and a line end ('\r', '\n') after it.
inline std::string_view trim(std::string_view s) {
  while (!s.empty() && is_space(s.front())) s.remove_prefix(1);
  while (!s.empty() && (is_space(s.back()) || s.back() == '\r' || s.back() == '\n')) s.remove_suffix(1);
  return s;
}

inline bool starts_with_i(std::string_view s, std::string_view prefix) {
  return s.size() >= prefix.size() && iequals(s.substr(0, prefix.size()), prefix);
}

inline std::string upper(std::string_view s) {
  std::string u(s);
  for (char& c : u) c = upper(c);
  return u;
}

}  // namespace postproc::gcode::text
