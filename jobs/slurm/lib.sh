# Sourced by the batch scripts: the end of a job.
#
# run_and_report NAME PID PREFIX: wait for the launcher PID (started in the background), passing
# it SIGUSR1 or SIGTERM that the batch shell receives (`sbatch --signal=B:USR1@300`; srun and
# mpirun forward it to every rank, where nndd stops at the end of its iteration and writes a
# restart point); then print each rank's peak memory from PREFIX.json, and after a stop by a
# signal (exit 4) the command that continues. Exits with the launcher's status.
run_and_report() {
  local name=$1 pid=$2 prefix=$3 status=0
  trap 'kill -USR1 "$pid" 2>/dev/null || true' USR1 TERM
  while :; do
    wait "$pid" && status=0 || status=$?
    kill -0 "$pid" 2>/dev/null || break
  done
  trap - USR1 TERM
  if [ -f "$prefix.json" ]; then
    local peaks
    peaks=$(tr -d ' \n' < "$prefix.json" | sed -n 's/.*"peak_memory_mib_per_rank":\[\([^]]*\)\].*/\1/p')
    peaks=$(echo "$peaks" | awk -F, '{for (i = 1; i <= NF; i++) printf "%s%.0f", (i > 1 ? ", " : ""), $i}')
    echo "$name: peak memory per rank (MiB): ${peaks:-unknown}${SLURM_MEM_PER_CPU:+; the job asked for $SLURM_MEM_PER_CPU MiB per CPU}"
  fi
  case $status in
    0) echo "$name: done: $prefix.h5, .xdmf, -contact.xdmf, -final.xdmf, .json" ;;
    4) echo "$name: stopped by a signal (the time limit?) at a restart point; continue with: NNDD_RESTART=1 sbatch jobs/slurm/$name (the same settings, any rank count)" ;;
    *) echo "$name: nndd exited with status $status" ;;
  esac
  return "$status"
}
