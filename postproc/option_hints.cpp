// "Did you mean" for mistyped commands and options (option_hints.hpp).
#include "option_hints.hpp"

#include <algorithm>
#include <cctype>
#include <string_view>
#include <vector>

#include <fmt/format.h>

namespace postproc::cli {
namespace {

/// Levenshtein distance (insertions, deletions, substitutions) of two short words.
std::size_t edit_distance(std::string_view a, std::string_view b) {
  std::vector<std::size_t> row(b.size() + 1);
  for (std::size_t j = 0; j <= b.size(); ++j) row[j] = j;
  for (std::size_t i = 1; i <= a.size(); ++i) {
    std::size_t diag = row[0];
    row[0] = i;
    for (std::size_t j = 1; j <= b.size(); ++j) {
      const std::size_t up = row[j];
      row[j] = std::min({row[j] + 1, row[j - 1] + 1, diag + (a[i - 1] == b[j - 1] ? 0 : 1)});
      diag = up;
    }
  }
  return row[b.size()];
}

/// The names nearest `word` (within a third of its length, at least 2 edits; or starting with it).
std::vector<std::string> nearest(std::string_view word, const std::vector<std::string>& names) {
  std::vector<std::pair<std::size_t, std::string>> scored;
  const std::size_t limit = std::max<std::size_t>(2, word.size() / 3);
  for (const std::string& n : names) {
    std::size_t d = edit_distance(word, n);
    if (word.size() >= 3 && n.rfind(word, 0) == 0) d = std::min<std::size_t>(d, 1);
    if (d <= limit) scored.emplace_back(d, n);
  }
  std::sort(scored.begin(), scored.end());
  std::vector<std::string> out;
  for (const auto& s : scored) {
    if (out.size() == 3 || (!out.empty() && s.first > scored.front().first)) break;
    out.push_back(s.second);
  }
  return out;
}

std::string did_you_mean(const std::vector<std::string>& names, std::string_view prefix) {
  if (names.empty()) return "";
  std::string s = "; did you mean ";
  for (std::size_t i = 0; i < names.size(); ++i)
    s += fmt::format("{}'{}{}'", i == 0 ? "" : (i + 1 == names.size() ? " or " : ", "), prefix, names[i]);
  return s + "?";
}

std::string command_path(const CLI::App* app) {
  std::string s;
  for (const CLI::App* a = app; a != nullptr; a = a->get_parent())
    s = a->get_parent() == nullptr ? "postproc" + (s.empty() ? "" : " " + s) : a->get_name() + (s.empty() ? "" : " " + s);
  return s;
}

bool looks_numeric(std::string_view t) {
  return t.size() >= 2 && t[0] == '-' && (std::isdigit(static_cast<unsigned char>(t[1])) != 0 || t[1] == '.');
}

}  // namespace

std::optional<std::string> unknown_word_hint(CLI::App& app, int argc, const char* const* argv) {
  CLI::App* cur = &app;
  for (int i = 1; i < argc; ++i) {
    const std::string_view t = argv[i];
    if (t == "--") break;
    if (t.rfind("--", 0) == 0) {
      const std::string name(t.substr(2, t.find('=') == std::string_view::npos ? std::string_view::npos : t.find('=') - 2));
      if (name.empty() || cur->get_option_no_throw("--" + name) != nullptr) continue;
      // Help and version are the application's own.
      if (name == "help" || (cur == &app && name == "version")) continue;
      std::vector<std::string> names;
      for (const CLI::Option* o : cur->get_options())
        for (const std::string& l : o->get_lnames()) names.push_back(l);
      return fmt::format("unknown option '--{}' for '{}'{} ({} --help lists its options)", name, command_path(cur),
                         did_you_mean(nearest(name, names), "--"), command_path(cur));
    }
    if (t.size() == 2 && t[0] == '-' && !looks_numeric(t)) {
      if (cur->get_option_no_throw(std::string(t)) != nullptr || t == "-h") continue;
      return fmt::format("unknown option '{}' for '{}' ({} --help lists its options)", t, command_path(cur),
                         command_path(cur));
    }
    if (t.empty() || t[0] == '-') continue;  // a value, or a negative number
    // A word: a command of the current level, or (below the top) a value or positional.
    std::vector<std::string> commands;
    CLI::App* sub = nullptr;
    for (CLI::App* s : cur->get_subcommands({})) {
      if (s->get_name().empty()) continue;
      commands.push_back(s->get_name());
      if (s->get_name() == t) sub = s;
    }
    if (sub != nullptr) {
      cur = sub;
      continue;
    }
    if (cur == &app && !commands.empty())
      return fmt::format("'{}' is not a postproc command{} (postproc --help lists them)", t,
                         did_you_mean(nearest(t, commands), ""));
  }
  return std::nullopt;
}

}  // namespace postproc::cli
