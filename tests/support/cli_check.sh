# Helpers for the CLI tests (tests/cli_*.sh), sourced after `dir` (a scratch folder) is set:
#   check NAME EXPECTED_EXIT COMMAND...  runs COMMAND, output in $dir/out and $dir/err
#   expect NAME CONDITION...             a check on files the previous commands made
#   finish                               prints the counts; exits 1 when any failed
fail=0 pass=0
check() {
  local name=$1 want=$2; shift 2
  "$@" >"$dir/out" 2>"$dir/err"; local got=$?
  if [ "$got" -eq "$want" ]; then pass=$((pass + 1)); echo "ok   $name"
  else fail=$((fail + 1)); echo "FAIL $name: exit $got, wanted $want"; cat "$dir/out" "$dir/err"; fi
}
expect() {
  local name=$1; shift
  if "$@"; then pass=$((pass + 1)); echo "ok   $name"; else fail=$((fail + 1)); echo "FAIL $name"; fi
}
finish() {
  echo "$pass passed, $fail failed"
  [ "$fail" -eq 0 ] || exit 1
  exit 0
}
