# Sourced by tools/same_bits.sh and tools/instructions.sh: the revision
# `rev` checked out in "$root/old" (removed again on exit) and the working
# tree as it is, committed or not and without its builds, copied to
# "$root/new". Needs `root` and `rev`; run from the repository root.
rm -rf "$root"
mkdir -p "$root/new"
git worktree add --detach "$root/old" "$rev" > /dev/null
trap 'git worktree remove --force "$root/old"' EXIT
git ls-files -co --exclude-standard -z | xargs -0 cp --parents -t "$root/new"
