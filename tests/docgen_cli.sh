#!/usr/bin/env bash
# Man pages and shell completions written by the build (postproc --generate-docs, docgen.cpp):
# one page per command and subcommand, naming every option the command's --help lists, that
# groff renders without a warning; a bash completion that completes commands, options and the
# values of options with a fixed set; zsh and fish files their shells accept (when installed).
# Usage: docgen_cli.sh POSTPROC GENERATED_DIR
set -euo pipefail
P=$1
gen=$2
fail() { echo "FAIL: $*"; exit 1; }
[[ -d $gen/man1 ]] || fail "$gen/man1 missing"

# The commands, read off --help (CLI11 lists them under "Subcommands:").
subcommands() { "$P" "$@" --help | awk '/^Subcommands:/ {on = 1; next} on && /^  [a-z]/ {print $1} on && /^$/ {on = 0}'; }
commands=()
for c in $(subcommands); do
  commands+=("$c")
  for s in $(subcommands "$c"); do commands+=("$c $s"); done
done
((${#commands[@]} >= 9)) || fail "only ${#commands[@]} commands found in postproc --help"

pages=0
for c in "" "${commands[@]}"; do
  page=$gen/man1/postproc${c:+-${c// /-}}.1
  [[ -s $page ]] || fail "no man page $page for 'postproc $c'"
  # Every long option of the command's --help is in its page (roff writes - as \-).
  # shellcheck disable=SC2086
  for opt in $("$P" $c --help | grep -oE -- '--[a-z][a-z0-9-]+' | sort -u); do
    grep -qF -- "${opt//-/\\-}" "$page" || fail "$page does not mention $opt"
  done
  if command -v groff > /dev/null; then
    warnings=$(groff -man -ww -z -Tutf8 "$page" 2>&1) || fail "groff failed on $page"
    [[ -z $warnings ]] || fail "groff warns on $page: $warnings"
  fi
  pages=$((pages + 1))
done

# bash: complete a few command lines as bash-completion would.
complete_line() {
  bash -c '
    compopt() { :; }
    source "$1"; shift
    COMP_WORDS=("$@"); COMP_CWORD=$((${#COMP_WORDS[@]} - 1))
    _postproc
    printf "%s\n" "${COMPREPLY[@]}"' _ "$gen/bash-completion/postproc" "$@"
}
expect() {  # expect WORD -- command line…
  local want=$1 got; shift 2
  got=$(complete_line "$@")
  grep -qxF -- "$want" <<< "$got" || fail "bash completion of '$*' lacks '$want' (got: $(tr '\n' ' ' <<< "$got"))"
}
expect compensate -- postproc comp
expect --mode -- postproc compensate --mo
expect contour -- postproc compensate --mode ""
expect plan -- postproc calibrate p
expect --kind -- postproc calibrate plan --ki
expect calculator -- postproc compensate --integer-input ""
expect simulate -- postproc calibrate s
expect merge -- postproc batch m
expect heidenhain-iso -- postproc check --dialect h

shells="bash"
if command -v zsh > /dev/null; then
  zsh -n "$gen/zsh/_postproc" || fail "zsh rejects _postproc"
  shells+=", zsh"
fi
if command -v fish > /dev/null; then
  fish --no-execute "$gen/fish/postproc.fish" || fail "fish rejects postproc.fish"
  shells+=", fish"
fi
echo "docgen_cli: $pages man pages, every --help option in its page; completions checked in $shells"
