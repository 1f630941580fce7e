#!/usr/bin/env bash
# Slurm for real on this machine: installs Debian's Slurm (slurmctld + slurmd on localhost, munge
# for authentication) if it is missing, starts private daemons (their configuration, state, logs
# and munge socket all in a temporary directory; nothing in /etc is changed), and then:
#   1. submits deploy/slurm/sweep.sbatch with deploy/plans/smoke.toml (120 noop points, 4 overlap points)
#      and scancels it mid-campaign (a hard stop: SIGTERM to everything, SIGKILL after KillWait),
#   2. resubmits it and stops it with USR1 to the batch script, as --signal=B:USR1@120 does
#      before the time limit (the graceful stop),
#   3. resubmits it once more and waits for it to finish (COMPLETED, exit code 0),
#   4. checks the database: every point done exactly once; what was done before each stop is
#      untouched after it; only the points in hand at the hard stop ran twice (their first run
#      left no result); the last allocation ran exactly what was left; Table 1 and Figure 2 built,
#   5. runs the login-node variant: a coordinator outside Slurm, `sweep.sbatch --coordinator URL`.
# Needs root (apt-get, daemons). Run by hand, or in CI with SWEEP_SLURM_TEST=1 (see .ci/run).
# Usage: deploy/slurm/test-on-localhost.sh [path/to/sweep]   (default: target/release/sweep)
set -euo pipefail
repo=$(cd "$(dirname "$0")/../.." && pwd)
sweep=$(realpath "${1:-$repo/target/release/sweep}")
[[ -x $sweep ]] || { echo "no sweep binary at $sweep (cargo build --release --bin sweep)" >&2; exit 2; }
[[ $(id -u) -eq 0 ]] || { echo "needs root: it installs and starts Slurm" >&2; exit 2; }
started=$(date +%s)
say() { echo "[slurm-test +$(($(date +%s) - started)) s] $*"; }

if ! command -v slurmctld >/dev/null || ! command -v slurmd >/dev/null || ! command -v munged >/dev/null; then
    say "installing Debian's slurmctld, slurmd, slurm-client and munge"
    export DEBIAN_FRONTEND=noninteractive
    apt-get update -q >/dev/null
    apt-get install -y -q --no-install-recommends slurmctld slurmd slurm-client munge >/dev/null
fi

work=$(mktemp -d /tmp/sweep-slurm.XXXXXX)
chmod 755 "$work"
munge_pid='' controller_started=''
cleanup() {
    if [[ -n $controller_started ]]; then
        # Jobs first (a failed check may leave one running), so that no slurmstepd outlives slurmd.
        scancel --partition=test >/dev/null 2>&1 || true
        for _ in $(seq 30); do [[ -z $(squeue -h 2>/dev/null) ]] && break; sleep 1; done
        scontrol shutdown >/dev/null 2>&1 || true
        sleep 1
    fi
    if [[ -n $munge_pid ]]; then kill "$munge_pid" 2>/dev/null || true; fi
    # The test's coordinator for step 5, if it is still up.
    if [[ -f $work/login.pid ]]; then kill "$(cat "$work/login.pid")" 2>/dev/null || true; fi
    if [[ ${KEEP:-0} == 1 ]]; then echo "kept $work"; else rm -rf "$work"; fi
}
trap cleanup EXIT

# munge, on a socket of its own, so that a system munged (if any) is left alone.
install -d -o munge -g munge -m 711 "$work/munge"
install -o munge -g munge -m 400 /dev/null "$work/munge/key"
head -c 1024 /dev/urandom >"$work/munge/key"
runuser -u munge -- munged --socket="$work/munge/socket" --key-file="$work/munge/key" \
    --pid-file="$work/munge/pid" --log-file="$work/munge/log" --seed-file="$work/munge/seed"
munge_pid=$(cat "$work/munge/pid")

node=$(hostname)
cpus=$(nproc)
mkdir -p "$work/state" "$work/spool"
cat >"$work/slurm.conf" <<EOF
ClusterName=sweeptest
SlurmctldHost=$node
SlurmctldPort=16817
SlurmdPort=16818
SlurmUser=root
AuthType=auth/munge
AuthInfo=socket=$work/munge/socket
CryptoType=crypto/munge
StateSaveLocation=$work/state
SlurmdSpoolDir=$work/spool
SlurmctldPidFile=$work/slurmctld.pid
SlurmdPidFile=$work/slurmd.pid
SlurmctldLogFile=$work/slurmctld.log
SlurmdLogFile=$work/slurmd.log
ProctrackType=proctrack/linuxproc
TaskPlugin=task/affinity
SchedulerType=sched/backfill
SelectType=select/cons_tres
SelectTypeParameters=CR_CPU
ReturnToService=2
MpiDefault=none
JobAcctGatherType=jobacct_gather/none
AccountingStorageType=accounting_storage/none
MinJobAge=3600
KillWait=10
NodeName=$node CPUs=$cpus State=UNKNOWN
PartitionName=test Nodes=$node Default=YES MaxTime=INFINITE State=UP
EOF
export SLURM_CONF=$work/slurm.conf
slurmctld -f "$SLURM_CONF"
controller_started=1
slurmd -f "$SLURM_CONF"
for _ in $(seq 60); do
    [[ $(sinfo -h -n "$node" -o %t 2>/dev/null) == idle ]] && break
    sleep 1
done
[[ $(sinfo -h -n "$node" -o %t) == idle ]] || { echo "slurmd did not come up"; cat "$work"/slurm*.log; exit 1; }
say "slurmctld + slurmd up: node $node, $cpus CPUs"

# The "shared filesystem": a directory both the submit host and the node see (here, the same one).
shared=$work/shared
mkdir -p "$shared/bin" "$shared/sweep"
cp "$sweep" "$shared/bin/sweep"
head -c 32 /dev/urandom | base64 >"$shared/sweep/token"
chmod 600 "$shared/sweep/token"
total=124
cp "$repo/deploy/plans/smoke.toml" "$shared/plan.toml"
db=$shared/sweep/campaign.db
export PATH=$shared/bin:$PATH SWEEP_LEASE_SECS=3
q() { sweep query "$1" --db "$db" --format csv | tail -n +2; }

submit() { sbatch --parsable --chdir="$shared" --output="$shared/slurm-%j.out" "$@"; }
job_state() { scontrol show job "$1" -o | sed -n 's/.*JobState=\([A-Z_]*\).*/\1/p'; }
wait_gone() { # until job $1 is no longer pending or running, at most $2 s
    for _ in $(seq "$2"); do
        case $(job_state "$1") in PENDING | RUNNING | COMPLETING | CONFIGURING) sleep 1 ;; *) return 0 ;; esac
    done
    echo "job $1 still $(job_state "$1") after $2 s"; exit 1
}

# Submits the campaign and waits until at least $1 points are done; prints the Slurm job id.
submit_until_done() {
    local job; job=$(submit "$repo/deploy/slurm/sweep.sbatch" plan.toml)
    for _ in $(seq 600); do
        done_now=$( [[ -f $db ]] && q "SELECT count(*) FROM jobs WHERE state = 'done'" 2>/dev/null || echo 0)
        [[ ${done_now:-0} -ge $1 ]] && break
        case $(job_state "$job") in
            PENDING | CONFIGURING | RUNNING) ;;
            *) echo "job $job ended early: $(job_state "$job")" >&2; cat "$shared/slurm-$job.out" >&2; exit 1 ;;
        esac
        sleep 0.2
    done
    echo "$job"
}
snapshot() { # the done points and their results, as of now, into $work/$1.*
    q "SELECT id, lease_token, finished_at FROM jobs WHERE state = 'done' ORDER BY id" >"$work/$1.done"
    q "SELECT job_id, row_index, attempt, worker_id, recorded_at FROM results ORDER BY job_id, row_index" >"$work/$1.results"
}
unchanged_since() { # the points done and results written before snapshot $1 (taken at time $2) are as they were
    q "SELECT id, lease_token, finished_at FROM jobs WHERE state = 'done' AND finished_at <= $2 ORDER BY id" >"$work/$1.done-now"
    q "SELECT job_id, row_index, attempt, worker_id, recorded_at FROM results WHERE recorded_at <= $2 ORDER BY job_id, row_index" >"$work/$1.results-now"
    if cmp -s "$work/$1.done" "$work/$1.done-now" && cmp -s "$work/$1.results" "$work/$1.results-now"; then
        say "ok: the $(wc -l <"$work/$1.done") points done before the $1 kept their lease, finish time and results"
    else
        echo "FAILED: points done before the $1 were touched"; diff "$work/$1.done" "$work/$1.done-now" | head; exit 1
    fi
}
check() { # description, SQL, expected
    local got; got=$(q "$2")
    if [[ $got == "$3" ]]; then say "ok: $1 ($got)"; else echo "FAILED: $1: got '$got', expected '$3'"; exit 1; fi
}
count_in() { q "SELECT count(*) FROM jobs WHERE state = '$1'"; }

# 1. Submit; a hard scancel once some points are done (SIGTERM to everything at once, SIGKILL after KillWait).
first=$(submit_until_done 30)
scancel "$first"
wait_gone "$first" 60
[[ $(job_state "$first") == CANCELLED ]] || { echo "job $first is $(job_state "$first"), not CANCELLED"; exit 1; }
hard_stop=$(date +%s.%N)
snapshot scancel
in_hand=$(count_in running)
say "job $first scancelled: $(count_in "done") of $total points done, $in_hand running, $(count_in queued) queued"
[[ $(count_in "done") -lt $total ]] || { echo "the scancel did not land mid-campaign"; exit 1; }

# 2. Resubmit; then the time-limit path: USR1 to the batch script (what --signal=B:USR1@120 sends).
second=$(submit_until_done 70)
scancel --batch --signal=USR1 "$second"
wait_gone "$second" 120
graceful_stop=$(date +%s.%N)
snapshot graceful-stop
say "job $second stopped by USR1: $(scontrol show job "$second" -o | grep -o 'JobState=[A-Z]*'), $(count_in "done") of $total done"
check "after the graceful stop no point is left running (finished or returned)" "SELECT count(*) FROM jobs WHERE state = 'running'" 0
[[ $(count_in "done") -lt $total ]] || { echo "the USR1 did not land mid-campaign"; exit 1; }
done_before_third=$(count_in "done")

# 3. Resubmit the same command once more: it finishes the campaign.
third=$(submit "$repo/deploy/slurm/sweep.sbatch" plan.toml)
wait_gone "$third" 600
state=$(scontrol show job "$third" -o | grep -o 'JobState=[A-Z]* Reason=[^ ]* .*ExitCode=[0-9:]*' | sed 's/ Reason.*ExitCode/ ExitCode/')
say "job $third: $state"
cat "$shared/slurm-$third.out"
[[ $state == "JobState=COMPLETED ExitCode=0:0" ]] || { cat "$shared/sweep/coordinator.log"; exit 1; }

# 4. The database: all done, once; what each allocation did is untouched by the next ones.
check "every point done" "SELECT count(*) FROM jobs WHERE state = 'done'" "$total"
check "no point failed, queued or running" "SELECT count(*) FROM jobs WHERE state <> 'done'" 0
check "every point has results" "SELECT count(DISTINCT job_id) FROM results" "$total"
check "each point's results come from one attempt of one worker" \
    "SELECT count(*) FROM (SELECT job_id FROM results GROUP BY job_id HAVING count(DISTINCT attempt) > 1 OR count(DISTINCT worker_id) > 1)" 0
check "one record per noop point" "SELECT count(*) FROM results r JOIN jobs j ON j.id = r.job_id WHERE j.kind = 'noop'" 120
unchanged_since scancel "$hard_stop"
unchanged_since graceful-stop "$graceful_stop"
check "the last allocation ran exactly the points left" "SELECT count(*) FROM jobs WHERE finished_at > $graceful_stop" $((total - done_before_third))
check "run twice: only the points in hand at the hard stop" "SELECT count(*) FROM jobs WHERE attempts > 1" "$in_hand"
check "no report refused as late" "SELECT count(*) FROM late_reports" 0
check "one worker per allocation, on $cpus cores" "SELECT count(*) || ' ' || min(json_array_length(cores)) FROM workers" "3 $cpus"
sweep report table1 --db "$db" >"$work/table1.md"
sweep report fig2 --db "$db" --out "$work/fig2.svg"
grep -q '<svg' "$work/fig2.svg" && say "ok: Table 1 ($(wc -l <"$work/table1.md") lines) and Figure 2 built from the database"

# 5. The login-node variant: a coordinator outside the allocation, workers joining it.
login_db=$shared/login.db
sweep coordinator --listen 127.0.0.1:0 --db "$login_db" --token-file "$shared/sweep/token" >"$work/login.out" 2>"$work/login.log" &
echo $! >"$work/login.pid"
for _ in $(seq 100); do grep -q '^listening on' "$work/login.out" && break; sleep 0.1; done
url=http://$(sed -n 's/^listening on //p' "$work/login.out")
printf 'name = "login"\n[[noop]]\ncount = 40\nduration_ms = 50\n' >"$shared/login.toml"
sweep submit "$shared/login.toml" --coordinator "$url" --token-file "$shared/sweep/token" >/dev/null 2>&1
third=$(submit "$repo/deploy/slurm/sweep.sbatch" --coordinator "$url")
wait_gone "$third" 300
[[ $(job_state "$third") == COMPLETED ]] || { cat "$shared/slurm-$third.out"; exit 1; }
db=$login_db check "login-node variant: every point done by the allocation's worker" \
    "SELECT count(*) FROM jobs WHERE state = 'done'" 40
kill "$(cat "$work/login.pid")" && rm "$work/login.pid"

say "passed in $(($(date +%s) - started)) s"
