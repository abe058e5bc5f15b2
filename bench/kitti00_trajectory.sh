# Sourced by the benchmarks on the KITTI 00 trajectory: sets root, data and traj (the trajectory
# beside the repository), or says the benchmark is skipped and exits.
root=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)
data=$("$root/tools/shared-data.sh" || true)
traj="$data/kitti-trajectories/00.txt"
if [[ -z "$data" || ! -f "$traj" ]]; then
  echo "(skipped: the KITTI 00 trajectory is not beside the repository)"
  exit 0
fi
