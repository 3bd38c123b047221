#!/usr/bin/env bash
# The man pages against the programs: every option `BINARY --help` lists appears in its man page, and every option
# the man page names is one --help lists, so neither can drift from the other.
# Usage: man_pages_test.sh BINARY MANPAGE [BINARY MANPAGE]...
set -uo pipefail
fail() { echo "man_pages_test: $*" >&2; exit 1; }
# Long options (--name) and short ones (-v) in the option column of CLI11's help: lines starting with "  -".
help_options() {
  "$1" --help | grep -E '^[[:space:]]+-' | sed -E 's/^[[:space:]]+//; s/[[:space:]].*$//' | tr ',' '\n' |
    sed -n 's/^\(--\?[A-Za-z0-9][A-Za-z0-9-]*\).*/\1/p' | sort -u
}
# The options the man page names up to the end of its OPTIONS section (EXAMPLES and FILES show other programs'
# options: curl -F, systemctl --now): roff's "\-" is a hyphen, font escapes (\fB, \fI, \fR) go.
page_options() {
  awk '/^\.SH/ && options {exit} /^\.SH OPTIONS/ {options = 1} !/^\.\\"/ {print}' "$1" |
    sed -E 's/\\-/-/g; s/\\f[BIRP]//g' |
    grep -oE '(^|[^A-Za-z0-9-])--?[A-Za-z0-9][A-Za-z0-9-]*' | sed -E 's/^[^-]//' | sort -u
}
(($# > 0 && $# % 2 == 0)) || fail "usage: man_pages_test.sh BINARY MANPAGE [BINARY MANPAGE]..."
while (($#)); do
  binary=$1 page=$2; shift 2
  [[ -r $page ]] || fail "no man page $page"
  mapfile -t listed < <(help_options "$binary")
  ((${#listed[@]} > 3)) || fail "$(basename "$binary") --help listed no options"
  mapfile -t named < <(page_options "$page")
  missing=$(comm -23 <(printf '%s\n' "${listed[@]}") <(printf '%s\n' "${named[@]}"))
  [[ -z $missing ]] || fail "$(basename "$page") lacks options of $(basename "$binary") --help: $(echo $missing)"
  # Options of the man page that --help does not list; single-letter words such as "-1" are values, not options.
  stale=$(comm -13 <(printf '%s\n' "${listed[@]}") <(printf '%s\n' "${named[@]}" | grep -E '^--|^-[A-Za-z]$'))
  [[ -z $stale ]] || fail "$(basename "$page") names options $(basename "$binary") --help does not have: $(echo $stale)"
  if command -v man >/dev/null; then
    warnings=$(LC_ALL=C.UTF-8 MANROFFSEQ='' MANWIDTH=80 man --warnings -l "$page" 2>&1 >/dev/null)
    [[ -z $warnings ]] || fail "$(basename "$page") has roff warnings: $warnings"
  fi
  echo "$(basename "$page"): all ${#listed[@]} options of $(basename "$binary") --help, none other"
done
