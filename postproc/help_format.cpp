#include "help_format.hpp"

#include <cstring>
#include <string>

#include "progress_bar.hpp"

namespace postproc::cli {
namespace {

std::size_t chars(std::string_view s) {
  std::size_t n = 0;
  for (const char c : s) n += (static_cast<unsigned char>(c) & 0xC0) != 0x80 ? 1 : 0;
  return n;
}

}  // namespace

std::string first_clause(std::string_view text, std::size_t width) {
  int depth = 0;
  std::size_t end = text.size();
  for (std::size_t i = 0; i + 1 < text.size(); ++i) {
    if (text[i] == '(') ++depth;
    if (text[i] == ')' && depth > 0) --depth;
    if (depth == 0 && text[i] == ';' && text[i + 1] == ' ') {
      end = i;
      break;
    }
  }
  std::string s(text.substr(0, end));
  if (chars(s) <= width) return s;
  // Cut at the last blank that leaves room for the ellipsis.
  std::size_t keep = 0, n = 0, last_blank = 0;
  for (std::size_t i = 0; i < s.size(); ++i) {
    if ((static_cast<unsigned char>(s[i]) & 0xC0) == 0x80) continue;
    if (n + 1 >= width) break;
    ++n;
    keep = i + 1;
    if (s[i] == ' ') last_blank = i;
  }
  if (last_blank > 0) keep = last_blank;
  while (keep < s.size() && (static_cast<unsigned char>(s[keep]) & 0xC0) == 0x80) ++keep;
  s.resize(keep);
  while (!s.empty() && (s.back() == ' ' || s.back() == ',' || s.back() == ':')) s.pop_back();
  return s + "…";
}

std::string wrap(std::string_view text, std::size_t width) {
  std::string out, line;
  std::size_t start = 0;
  while (start <= text.size()) {
    std::size_t end = text.find(' ', start);
    if (end == std::string_view::npos) end = text.size();
    const std::string_view w = text.substr(start, end - start);
    if (!line.empty() && chars(line) + 1 + chars(w) >= width) {
      out += line + "\n";
      line.clear();
    }
    if (!w.empty()) line += (line.empty() ? "" : " ") + std::string(w);
    start = end + 1;
  }
  return out + line;
}

std::string ScreenHelpFormatter::make_description(const CLI::App* app) const {
  const std::string d = CLI::Formatter::make_description(app);
  if (full_) return d;
  // CLI11 ends the description with a newline; wrap what is before it.
  std::string body = d;
  while (!body.empty() && body.back() == '\n') body.pop_back();
  return wrap(body, terminal_columns()) + "\n";
}

std::string ScreenHelpFormatter::make_subcommand(const CLI::App* sub) const {
  if (full_) return CLI::Formatter::make_subcommand(sub);
  std::string name = "  " + sub->get_display_name(true);
  const std::size_t col = get_column_width();
  if (name.size() < col) name.resize(col, ' ');
  else name += "\n" + std::string(col, ' ');
  const std::size_t columns = terminal_columns();
  return name + first_clause(sub->get_description(), columns > col + 12 ? columns - col - 2 : 10) + "\n";
}

std::string ScreenHelpFormatter::make_option_desc(const CLI::Option* opt) const {
  const std::string desc = CLI::Formatter::make_option_desc(opt);
  if (full_) return desc;
  const std::size_t columns = terminal_columns();
  const std::size_t room = columns > get_column_width() + 12 ? columns - get_column_width() - 2 : 10;
  return first_clause(desc, room);
}

std::string ScreenHelpFormatter::make_footer(const CLI::App* app) const {
  std::string f = CLI::Formatter::make_footer(app);
  if (full_ || app->get_parent() == nullptr) return f;
  std::string name = app->get_name();
  for (const CLI::App* p = app->get_parent(); p != nullptr && p->get_parent() != nullptr; p = p->get_parent())
    name = p->get_name() + "-" + name;
  return f + "\n" + wrap("Descriptions shortened to the screen: --help-all or man postproc-" + name + " has them whole.",
                         terminal_columns()) +
         "\n";
}

bool take_help_all(int argc, char** argv) {
  bool found = false;
  for (int i = 1; i < argc; ++i)
    if (std::strcmp(argv[i], "--help-all") == 0) {
      static char help[] = "--help";
      argv[i] = help;
      found = true;
    }
  return found;
}

}  // namespace postproc::cli
