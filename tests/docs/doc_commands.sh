#!/usr/bin/env bash
# Runs the commands a document shows, as a user would type them, so the docs
# cannot go stale silently. Every ```sh block of the document must follow a
# doc-test annotation on the line before it:
#
#   <!-- doc-test: run [expect="REGEX"]... [file=PATH]... -->
#       run the block (bash, set -euo pipefail) in a fresh folder holding a
#       copy of data/ and deploy/, with gyrotc first on PATH; it must exit 0,
#       every expect= regex (grep -E) must match its output and every file=
#       must exist and be non-empty afterwards.
#   <!-- doc-test: check (WHY IT DOES NOT RUN HERE) -->
#       a board, root or hour-long command: not run, but checked.
#
# Every sh block, run or not, and every inline code span of the prose that
# starts with `gyrotc CMD` or `scripts/` is checked: each `gyrotc COMMAND`
# (also after sudo) must be a command and each --option it shows must be in
# that command's --help; each `gyrotc-emu ctl NAME`/`gyrotc-emu COMMAND`
# likewise when the emulator is built; each scripts/NAME it names must exist,
# be executable and parse (bash -n), and the options shown must be in its
# --help when it has one. A run block's folder also holds a copy of scripts/.
# A failure names the document and line, the command, and the output's end.
#
# Usage: doc_commands.sh --doc FILE --source DIR --bin DIR [--emu PATH] --work DIR
set -uo pipefail

doc= source= bin= emu= work=
while [ $# -gt 0 ]; do
  case "$1" in
    --doc) doc=$2; shift 2 ;;
    --source) source=$2; shift 2 ;;
    --bin) bin=$2; shift 2 ;;
    --emu) emu=$2; shift 2 ;;
    --work) work=$2; shift 2 ;;
    -h|--help) sed -n '2,22p' "$0" | sed 's/^# \{0,1\}//'; exit 0 ;;
    *) echo "doc_commands.sh: unknown argument '$1' (see --help)" >&2; exit 2 ;;
  esac
done
for v in doc source bin work; do
  [ -n "${!v}" ] || { echo "doc_commands.sh: --$v is required (see --help)" >&2; exit 2; }
done
[ -x "$bin/gyrotc" ] || { echo "doc_commands.sh: no executable $bin/gyrotc" >&2; exit 2; }
name=${doc#"$source"/}
failures=0
fail() {  # LINE MESSAGE
  echo "$name:$1: $2" >&2
  failures=$((failures + 1))
}

# The help text of a gyrotc (or gyrotc-emu) command, cached.
declare -A helps
help_of() {  # EXE COMMAND...
  local key="$*"
  if [ -z "${helps[$key]+x}" ]; then
    helps[$key]=$("$@" --help 2>&1) || helps[$key]="__no_such_command__"
  fi
  printf '%s' "${helps[$key]}"
}

# The regex of the line of a --help that defines OPTION (not one that only
# mentions it): "  --plot TEXT", "  -o,--out DIR", "  -h, --help".
option_line() {  # OPTION
  printf '^[[:space:]]*(-[[:alnum:]],[[:space:]]*)?%s([ ,=]|$)' "$1"
}

# Fails LINE for each --option among WORDS (up to a shell operator) that
# HELP does not define; WHAT names the command in the message.
check_options() {  # LINE WHAT HELP WORDS...
  local line=$1 what=$2 help=$3 opt
  shift 3
  for opt in "$@"; do
    case "$opt" in \&\&|\||\;|\>|\>\>) break ;; esac
    opt=${opt#[}
    opt=${opt%%]*}
    opt=${opt%%=*}
    case "$opt" in
      --*) grep -qE -- "$(option_line "$opt")" <<< "$help" || fail "$line" "$what has no option $opt (not in its --help)" ;;
    esac
  done
}

# Checks one logical line (continuations joined) of a block.
check_line() {  # LINE TEXT
  local line=$1 text=$2 words i w cmd exe
  text=${text%%#*}                          # drop a comment
  read -r -a words <<< "$text"
  for ((i = 0; i < ${#words[@]}; ++i)); do
    w=${words[i]}
    case "$w" in
      *scripts/*.sh)
        local script=${w#./}
        script=scripts/${script#*scripts/}
        if [ ! -x "$source/$script" ]; then
          fail "$line" "$script: no such executable script"
        elif ! bash -n "$source/$script" 2> "$work/syntax.log"; then
          fail "$line" "$script: a syntax error: $(head -n 1 "$work/syntax.log")"
        elif grep -qE -- '-h *\| *--help|--help\)' "$source/$script"; then
          # A script with a --help: every option shown must be in it.
          check_options "$line" "$script" "$(help_of "$source/$script")" "${words[@]:i+1}"
        fi
        ;;
    esac
    if [ $i -gt 0 ] && [ "${words[i - 1]}" = -u ]; then continue; fi   # sudo -u gyrotc: the user
    if [ "$w" = gyrotc ] || [ "$w" = gyrotc-emu ]; then
      [ $((i + 1)) -lt ${#words[@]} ] || continue
      cmd=${words[i + 1]}
      case "$cmd" in --*|\$*|\<*) continue ;; esac
      if [ "$w" = gyrotc ]; then
        exe=("$bin/gyrotc" "$cmd")
      else
        [ -n "$emu" ] || continue
        exe=("$emu" "$cmd")
        if [ "$cmd" = ctl ] && [ $((i + 2)) -lt ${#words[@]} ]; then exe+=("${words[i + 2]}"); fi
      fi
      local help
      help=$(help_of "${exe[@]}")
      if [ "$help" = "__no_such_command__" ]; then
        fail "$line" "'${w} ${exe[*]:1}': no such command (its --help fails)"
        continue
      fi
      check_options "$line" "'${w} ${exe[*]:1}'" "$help" "${words[@]:i+2}"
    fi
  done
}

# Extracts the blocks: START_LINE<TAB>ANNOTATION, then the block's lines.
mkdir -p "$work"
blocks=0 ran=0
in_block=0 prev="" start=0 annotation="" body=""
run_block() {  # START ANNOTATION BODY
  local start=$1 annotation=$2 body=$3 n=0 logical="" first=0 raw
  # Check every logical line.
  while IFS= read -r raw; do
    n=$((n + 1))
    [ -z "$logical" ] && first=$((start + n))
    if [[ $raw == *\\ ]]; then logical+="${raw%\\} "; continue; fi
    logical+=$raw
    check_line "$first" "$logical"
    logical=""
  done <<< "$body"
  local mode=${annotation%% *}
  case "$mode" in
    check) return ;;
    run) ;;
    *) fail "$start" "a sh block without a doc-test annotation on the line before it (run or check)"; return ;;
  esac
  ran=$((ran + 1))
  local dir="$work/line-$start"
  rm -rf "$dir"
  mkdir -p "$dir"
  cp -r "$source/data" "$source/deploy" "$source/scripts" "$dir/"
  printf 'set -euo pipefail\n%s\n' "$body" > "$dir/block.sh"
  local rc=0
  (cd "$dir" && PATH="$bin:$PATH" bash block.sh > output.log 2>&1) || rc=$?
  if [ "$rc" -ne 0 ]; then
    fail "$start" "the block failed (exit $rc); its end:"
    tail -n 15 "$dir/output.log" | sed 's/^/    /' >&2
    return
  fi
  local expect file
  while IFS= read -r expect; do
    [ -n "$expect" ] || continue
    grep -qE -- "$expect" "$dir/output.log" ||
      fail "$start" "the output lacks /$expect/, which the text quotes (output: $dir/output.log)"
  done < <(grep -oE 'expect="[^"]*"' <<< "$annotation" | sed -E 's/^expect="(.*)"$/\1/')
  while IFS= read -r file; do
    [ -n "$file" ] || continue
    [ -s "$dir/$file" ] || fail "$start" "the block did not write $file, which the text promises"
  done < <(grep -oE 'file=[^ ]+' <<< "$annotation" | sed 's/^file=//')
}

lineno=0
indent=""
while IFS= read -r text || [ -n "$text" ]; do
  lineno=$((lineno + 1))
  if [ $in_block -eq 1 ]; then
    text=${text#"$indent"}  # a block inside a list item is indented
    if [[ $text == '```'* ]]; then
      [ "$annotation" = other ] || run_block "$start" "$annotation" "$body"
      in_block=0
    else
      body+="${body:+$'\n'}$text"
    fi
    continue
  fi
  indent=${text%%[![:space:]]*}
  text=${text#"$indent"}
  if [[ $text == '```'* ]]; then
    in_block=1 start=$lineno body="" annotation=""
    if [[ $text == '```sh'* ]]; then
      blocks=$((blocks + 1))
      if [[ $prev =~ ^\<\!--\ doc-test:\ (.*)\ --\>$ ]]; then annotation=${BASH_REMATCH[1]}; fi
    else
      annotation=other
    fi
  else
    # Commands in the prose's inline code: `gyrotc CMD --opt`, `scripts/X.sh --opt`.
    while IFS= read -r span; do
      span=${span:1:${#span}-2}
      [[ $span =~ ^(sudo\ )?(gyrotc\ [a-z]|(\./)?scripts/) ]] && check_line "$lineno" "$span"
    done < <(grep -oE '`[^`]+`' <<< "$text")
  fi
  prev=$text
done < "$doc"

if [ $failures -ne 0 ]; then
  echo "$name: $failures failure(s) in $blocks sh blocks" >&2
  exit 1
fi
echo "$name: $blocks sh blocks checked, $ran run"
