// Man pages and shell completions written from the CLI11 definitions of every command, so they
// cannot drift from the options the program really takes. Called by the build (hidden
// `postproc --generate-docs DIR`), installed by `cmake --install`.
#include "docgen.hpp"

#include <algorithm>
#include <filesystem>
#include <fstream>
#include <functional>
#include <string>
#include <vector>

#include <fmt/format.h>

#include "common.hpp"

namespace postproc::cli {
namespace {

namespace fs = std::filesystem;

/// A command with its path of names ("calibrate", "plan") and the page in docs/ that explains it.
struct Command {
  const CLI::App* app;
  std::vector<std::string> path;  ///< empty for the top-level program
};

std::vector<Command> commands_of(const CLI::App& root) {
  std::vector<Command> out{{&root, {}}};
  std::function<void(const CLI::App*, std::vector<std::string>)> walk = [&](const CLI::App* app,
                                                                             std::vector<std::string> path) {
    for (const CLI::App* sub : app->get_subcommands([](const CLI::App*) { return true; })) {
      auto p = path;
      p.push_back(sub->get_name());
      out.push_back({sub, p});
      walk(sub, p);
    }
  };
  walk(&root, {});
  return out;
}

std::string joined(const std::vector<std::string>& v, const std::string& sep) {
  std::string s;
  for (std::size_t i = 0; i < v.size(); ++i) s += (i ? sep : "") + v[i];
  return s;
}

/// The docs/ page of a command (docs/README.md lists them).
std::string doc_page(const std::vector<std::string>& path) {
  if (path.empty()) return "README.md";
  const std::string& top = path.front();
  if (top == "predict" || top == "simulate") return "contour.md";
  return top + ".md";
}

/// Options of a command that a user gives (no positional arguments), in definition order.
std::vector<const CLI::Option*> named_options(const CLI::App& app) {
  return app.get_options([](const CLI::Option* o) { return o->nonpositional(); });
}
std::vector<const CLI::Option*> positionals(const CLI::App& app) {
  return app.get_options([](const CLI::Option* o) { return !o->nonpositional() && o->get_positional(); });
}

bool takes_value(const CLI::Option* o) { return o->get_expected_max() > 0; }

/// A value that is a number (INT, UINT, FLOAT, NUMBER…): nothing to complete, not a file.
bool numeric(const CLI::Option* o) {
  const std::string t = o->get_type_name();
  for (const char* n : {"INT", "UINT", "FLOAT", "NUMBER"})
    if (t.rfind(n, 0) == 0) return true;
  return false;
}

/// The members of a CLI::IsMember check, read off the type name ("TEXT:{a,b,c}"); empty when none.
std::vector<std::string> choices(const CLI::Option* o) {
  const std::string t = o->get_type_name();
  const auto open = t.find('{');
  const auto close = t.find('}', open == std::string::npos ? 0 : open);
  if (open == std::string::npos || close == std::string::npos) return {};
  std::vector<std::string> out;
  std::string cur;
  for (char c : t.substr(open + 1, close - open - 1)) {
    if (c == ',') {
      out.push_back(cur);
      cur.clear();
    } else if (c != ' ') {
      cur += c;
    }
  }
  if (!cur.empty()) out.push_back(cur);
  return out;
}

/// A value's placeholder: the choices, else the type (TEXT, INT, FLOAT, …) without checks.
std::string placeholder(const CLI::Option* o) {
  const auto c = choices(o);
  if (!c.empty()) return joined(c, "|");
  std::string t = o->get_type_name();
  const auto colon = t.find(':');
  if (colon != std::string::npos) t.resize(colon);
  return t.empty() ? "VALUE" : t;
}

std::string option_names(const CLI::Option* o, const std::string& sep) {
  std::vector<std::string> n;
  for (const auto& s : o->get_snames()) n.push_back("-" + s);
  for (const auto& l : o->get_lnames()) n.push_back("--" + l);
  return joined(n, sep);
}

/// The first clause of a description, for completion menus.
std::string short_text(std::string d) {
  for (const char* stop : {"; ", ": ", " ("}) {
    const auto at = d.find(stop);
    if (at != std::string::npos && at > 12) d.resize(at);
  }
  if (d.size() > 70) d = d.substr(0, 67) + "...";
  return d;
}

// --- man pages -------------------------------------------------------------------------------

/// Text escaped for roff: backslashes, hyphens, a leading dot or quote, and every non-ASCII
/// character as \[uXXXX] (µ, –, …: groff and mandoc read them without a UTF-8 preprocessor).
std::string roff(const std::string& s) {
  std::string out;
  for (std::size_t i = 0; i < s.size(); ++i) {
    const auto c = static_cast<unsigned char>(s[i]);
    if (c == '\\') {
      out += "\\e";
    } else if (c == '-') {
      out += "\\-";
    } else if (c < 0x80) {
      out += static_cast<char>(c);
    } else {
      const int extra = c >= 0xF0 ? 3 : c >= 0xE0 ? 2 : c >= 0xC0 ? 1 : 0;
      char32_t cp = c & (0x3F >> extra);
      for (int k = 0; k < extra && i + 1 < s.size(); ++k) cp = (cp << 6) | (static_cast<unsigned char>(s[++i]) & 0x3F);
      out += fmt::format("\\[u{:04X}]", static_cast<std::uint32_t>(cp));
    }
  }
  if (!out.empty() && (out[0] == '.' || out[0] == '\'')) out.insert(0, "\\&");
  return out;
}

std::string upper(std::string s) {
  std::transform(s.begin(), s.end(), s.begin(), [](unsigned char c) { return static_cast<char>(std::toupper(c)); });
  return s;
}

const char* const kExitStatus = R"(.TP
.B 0
accepted (for \fBconvert\fR: written)
.TP
.B 1
accepted, but the program contains unresolved constructs (PP\-U...) that compensation refuses
without pass\-through (\fBcheck\fR, \fBdump\fR); \fBdiff \-\-fail\-above\fR: a deviation exceeds the limit
.TP
.B 2
refused: the program, the machine file (PP\-M...) or a measurement file (PP\-C...) has errors, or
the result is not a usable machine; nothing was written. \fBbatch\fR: at least one program was
refused or failed (the others were written); \fBbatch merge\fR: a shard is missing or a program
was not compensated
.TP
.B 64
bad command line, or an output would overwrite an input of the run (PP\-E901), or two outputs
name one file (PP\-E902)
.TP
.B 66
an input cannot be opened or read, or is a folder or a device (PP\-E903)
.TP
.B 70
internal error (a bug: please report it with the input)
.TP
.B 73
an output cannot be created, written or renamed into place; no output of the run was replaced
.TP
.B 128+N
stopped by signal N; every temporary removed, no output replaced
)";

/// A command's description without the program's own name in front ("postproc: read, …").
std::string description_of(const CLI::App& app) {
  std::string d = app.get_description();
  if (d.rfind("postproc: ", 0) == 0) d.erase(0, 10);
  return d;
}

std::string man_page(const Command& c, const std::vector<Command>& all, const std::string& version) {
  const std::string name = c.path.empty() ? "postproc" : "postproc-" + joined(c.path, "-");
  const std::string invocation = c.path.empty() ? "postproc" : "postproc " + joined(c.path, " ");
  std::string m = fmt::format(".TH {} 1 \"\" \"postproc {}\" \"postproc manual\"\n", upper(name), version);
  m += fmt::format(".SH NAME\n{} \\- {}\n", roff(name), roff(description_of(*c.app)));
  m += ".SH SYNOPSIS\n";
  std::string synopsis = fmt::format(".B {}\n", roff(invocation));
  if (c.path.empty()) {
    synopsis += "\\fICOMMAND\\fR [\\fIOPTIONS\\fR]\n.br\n.B postproc \\-\\-version\n";
  } else {
    const auto subs = c.app->get_subcommands([](const CLI::App*) { return true; });
    if (!subs.empty()) synopsis += "[\\fICOMMAND\\fR] ";
    synopsis += "[\\fIOPTIONS\\fR]";
    for (const CLI::Option* p : positionals(*c.app)) {
      const bool many = p->get_items_expected_max() > 1;
      synopsis += fmt::format(" {}\\fI{}\\fR{}{}", p->get_required() ? "" : "[", roff(p->get_name(true)),
                              many ? "..." : "", p->get_required() ? "" : "]");
    }
    synopsis += "\n";
  }
  m += synopsis;
  m += ".SH DESCRIPTION\n";
  m += roff(description_of(*c.app)) + ".\n";
  m += fmt::format(".PP\nThe full description, with examples: \\fIdocs/{}\\fR in postproc's documentation "
                   "(installed under \\fIshare/doc/postproc/docs/\\fR).\n",
                   doc_page(c.path));
  std::vector<const Command*> children;
  for (const Command& o : all)
    if (o.path.size() == c.path.size() + 1 && std::equal(c.path.begin(), c.path.end(), o.path.begin()))
      children.push_back(&o);
  if (!children.empty()) {
    m += ".SH COMMANDS\n";
    for (const Command* ch : children) {
      m += fmt::format(".TP\n.BR postproc\\-{} (1)\n{}\n", roff(joined(ch->path, "-")),
                       roff(description_of(*ch->app)));
    }
  }
  const auto pos = positionals(*c.app);
  const auto opts = named_options(*c.app);
  if (!pos.empty() || !opts.empty()) m += ".SH OPTIONS\n";
  for (const CLI::Option* p : pos) {
    m += fmt::format(".TP\n\\fI{}\\fR\n{}{}\n", roff(p->get_name(true)), roff(p->get_description()),
                     p->get_required() ? " (required)" : "");
  }
  for (const CLI::Option* o : opts) {
    std::string names;
    for (const auto& s : o->get_snames()) names += fmt::format("{}\\fB\\-{}\\fR", names.empty() ? "" : ", ", roff(s));
    for (const auto& l : o->get_lnames())
      names += fmt::format("{}\\fB\\-\\-{}\\fR", names.empty() ? "" : ", ", roff(l));
    if (takes_value(o)) names += fmt::format(" \\fI{}\\fR", roff(placeholder(o)));
    std::string text = roff(o->get_description());
    if (!o->get_default_str().empty()) text += fmt::format(" (default: {})", roff(o->get_default_str()));
    if (o->get_required()) text += " (required)";
    if (o->get_expected_max() > 1 || o->get_items_expected_max() > 1) text += " (repeatable)";
    m += fmt::format(".TP\n{}\n{}\n", names, text);
  }
  if (!c.path.empty())
    m += ".TP\n\\fB\\-\\-help\\-all\\fR\nthe help with every option's whole description (\\fB\\-\\-help\\fR shortens "
         "them to fit the screen)\n";
  m += ".SH EXIT STATUS\n";
  m += kExitStatus;
  m += ".SH SEE ALSO\n";
  std::vector<std::string> see;
  if (!c.path.empty()) see.push_back("\\fBpostproc\\fR(1)");
  for (const Command& o : all)
    if (!o.path.empty() && o.app != c.app && o.path.size() == 1)
      see.push_back(fmt::format("\\fBpostproc\\-{}\\fR(1)", roff(o.path.front())));
  m += joined(see, ", ") + "\n";
  return m;
}

// --- completions -----------------------------------------------------------------------------

/// A shell word in single quotes.
std::string sq(const std::string& s) {
  std::string out = "'";
  for (char c : s) out += c == '\'' ? std::string("'\\''") : std::string(1, c);
  return out + "'";
}

std::string bash_completion(const std::vector<Command>& all) {
  std::string s = R"(# bash completion for postproc (generated from its command definitions)
_postproc() {
  local cur prev path w i
  cur=${COMP_WORDS[COMP_CWORD]}
  prev=${COMP_WORDS[COMP_CWORD-1]}
  path=""
  for ((i = 1; i < COMP_CWORD; i++)); do
    w=${COMP_WORDS[i]}
    case "$path $w" in
)";
  for (const Command& c : all) {
    if (c.path.empty()) continue;
    std::vector<std::string> parent(c.path.begin(), c.path.end() - 1);
    s += fmt::format("      {}) path={} ;;\n", sq(joined(parent, " ") + " " + c.path.back()),
                     sq(joined(c.path, " ")));
  }
  s += R"(    esac
  done
  local opts="" subs="" values="" file_value=0
  case "$path" in
)";
  for (const Command& c : all) {
    std::vector<std::string> opts, subs;
    for (const CLI::Option* o : named_options(*c.app)) {
      for (const auto& n : o->get_snames()) opts.push_back("-" + n);
      for (const auto& n : o->get_lnames()) opts.push_back("--" + n);
    }
    for (const CLI::App* sub : c.app->get_subcommands([](const CLI::App*) { return true; }))
      subs.push_back(sub->get_name());
    s += fmt::format("    {}) opts={}; subs={}\n", sq(joined(c.path, " ")), sq(joined(opts, " ")), sq(joined(subs, " ")));
    s += "      case \"$prev\" in\n";
    for (const CLI::Option* o : named_options(*c.app)) {
      if (!takes_value(o)) continue;
      const auto ch = choices(o);
      s += fmt::format("        {}) {} ;;\n", option_names(o, "|"),
                       !ch.empty() ? "values=" + sq(joined(ch, " "))
                       : numeric(o) ? std::string("return")
                                    : std::string("file_value=1"));
    }
    s += "      esac ;;\n";
  }
  s += R"(  esac
  if [[ -n $values ]]; then
    mapfile -t COMPREPLY < <(compgen -W "$values" -- "$cur"); return
  fi
  if ((file_value)); then
    mapfile -t COMPREPLY < <(compgen -f -- "$cur"); compopt -o filenames 2> /dev/null; return
  fi
  if [[ $cur == -* ]]; then
    mapfile -t COMPREPLY < <(compgen -W "$opts" -- "$cur"); return
  fi
  mapfile -t COMPREPLY < <(compgen -W "$subs" -- "$cur")
  if [[ -n $path ]]; then
    local files; mapfile -t files < <(compgen -f -- "$cur")
    COMPREPLY+=("${files[@]}"); compopt -o filenames 2> /dev/null
  fi
}
complete -F _postproc postproc
)";
  return s;
}

/// Text for a zsh _arguments spec: brackets and colons escaped.
std::string zsh_text(const std::string& t) {
  std::string out;
  for (char c : short_text(t)) {
    if (c == '[' || c == ']' || c == ':' || c == '\\') out += '\\';
    out += c == '\'' ? std::string("'\\''") : std::string(1, c);
  }
  return out;
}

std::string zsh_function_name(const std::vector<std::string>& path) {
  return path.empty() ? "_postproc" : "_postproc_" + joined(path, "_");
}

std::string zsh_completion(const std::vector<Command>& all) {
  std::string s = "#compdef postproc\n# zsh completion for postproc (generated from its command definitions)\n\n";
  for (auto it = all.rbegin(); it != all.rend(); ++it) {
    const Command& c = *it;
    const auto subs = c.app->get_subcommands([](const CLI::App*) { return true; });
    s += zsh_function_name(c.path) + "() {\n";
    std::vector<std::string> specs;
    for (const CLI::Option* o : named_options(*c.app)) {
      std::vector<std::string> names;
      for (const auto& n : o->get_snames()) names.push_back("-" + n);
      for (const auto& n : o->get_lnames()) names.push_back("--" + n);
      const bool repeat = o->get_expected_max() > 1 || o->get_items_expected_max() > 1;
      std::string action;
      if (takes_value(o)) {
        const auto ch = choices(o);
        action = ":" + zsh_text(placeholder(o)) + ":" +
                 (!ch.empty() ? "(" + joined(ch, " ") + ")" : numeric(o) ? std::string(" ") : std::string("_files"));
      }
      const std::string text = "[" + zsh_text(o->get_description()) + "]" + action;
      if (names.size() == 1) {
        specs.push_back("'" + std::string(repeat ? "*" : "") + names[0] + text + "'");
      } else {
        specs.push_back("'" + std::string(repeat ? "*" : "(" + joined(names, " ") + ")") + "'{" + joined(names, ",") +
                        "}'" + text + "'");
      }
    }
    if (!subs.empty()) {
      specs.push_back("'1: :->command'");
      specs.push_back("'*:: :->args'");
    } else {
      specs.push_back("'*:file:_files'");
    }
    s += "  local state line\n  _arguments -C \\\n";
    for (const auto& sp : specs) s += "    " + sp + " \\\n";
    s.resize(s.size() - 3);
    s += "\n";
    if (!subs.empty()) {
      s += "  case $state in\n    command)\n      local -a commands=(\n";
      for (const CLI::App* sub : subs)
        s += fmt::format("        '{}:{}'\n", sub->get_name(), zsh_text(sub->get_description()));
      s += "      )\n      _describe command commands ;;\n    args)\n      case $line[1] in\n";
      for (const CLI::App* sub : subs) {
        auto p = c.path;
        p.push_back(sub->get_name());
        s += fmt::format("        {}) {} ;;\n", sub->get_name(), zsh_function_name(p));
      }
      s += "      esac ;;\n  esac\n";
    }
    s += "}\n\n";
  }
  // Autoloaded from fpath: complete now; sourced: register.
  s += "if [[ $funcstack[1] == _postproc ]]; then\n  _postproc \"$@\"\nelse\n  compdef _postproc postproc\nfi\n";
  return s;
}

std::string fish_completion(const std::vector<Command>& all) {
  std::string s = "# fish completion for postproc (generated from its command definitions)\n"
                  "complete -c postproc -f\n";
  // A command is selected when its words were seen and none of its subcommands' (calibrate vs
  // calibrate plan); `simulate` is both a top-level command and a calibrate subcommand.
  auto condition = [&](const Command& c) {
    if (c.path.empty()) return std::string("__fish_use_subcommand");
    std::vector<std::string> parts;
    for (const auto& w : c.path) parts.push_back("__fish_seen_subcommand_from " + w);
    if (c.path.size() == 1) {
      for (const Command& o : all)
        if (o.path.size() == 2 && o.path.back() == c.path.front())
          parts.push_back("not __fish_seen_subcommand_from " + o.path.front());
    }
    const auto subs = c.app->get_subcommands([](const CLI::App*) { return true; });
    if (!subs.empty()) {
      std::vector<std::string> names;
      for (const CLI::App* sub : subs) names.push_back(sub->get_name());
      parts.push_back("not __fish_seen_subcommand_from " + joined(names, " "));
    }
    return joined(parts, "; and ");
  };
  for (const Command& c : all) {
    const std::string cond = condition(c);
    for (const CLI::App* sub : c.app->get_subcommands([](const CLI::App*) { return true; }))
      s += fmt::format("complete -c postproc -n {} -a {} -d {}\n", sq(cond), sub->get_name(),
                       sq(short_text(sub->get_description())));
    for (const CLI::Option* o : named_options(*c.app)) {
      std::string line = "complete -c postproc -n " + sq(cond);
      for (const auto& n : o->get_snames()) line += " -s " + n;
      for (const auto& n : o->get_lnames()) line += " -l " + n;
      if (takes_value(o)) {
        const auto ch = choices(o);
        line += !ch.empty() ? " -x -a " + sq(joined(ch, " ")) : numeric(o) ? std::string(" -x") : std::string(" -r -F");
      }
      line += " -d " + sq(short_text(o->get_description()));
      s += line + "\n";
    }
    if (!c.path.empty() && !positionals(*c.app).empty()) s += "complete -c postproc -n " + sq(cond) + " -F\n";
  }
  return s;
}

void write_text(const fs::path& file, const std::string& text) {
  fs::create_directories(file.parent_path());
  std::ofstream f(file, std::ios::binary);
  f << text;
  if (!f.flush()) throw Error(ExitCode::cannot_write, fmt::format("{}: cannot write", file.string()));
}

}  // namespace

void generate_docs(const CLI::App& app, const std::string& dir, const std::string& version) {
  const auto all = commands_of(app);
  const fs::path root(dir);
  for (const Command& c : all) {
    const std::string name = c.path.empty() ? "postproc" : "postproc-" + joined(c.path, "-");
    write_text(root / "man1" / (name + ".1"), man_page(c, all, version));
  }
  write_text(root / "bash-completion" / "postproc", bash_completion(all));
  write_text(root / "zsh" / "_postproc", zsh_completion(all));
  write_text(root / "fish" / "postproc.fish", fish_completion(all));
}

}  // namespace postproc::cli
