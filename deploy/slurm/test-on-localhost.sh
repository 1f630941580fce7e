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
#   5. runs the login-node variant: a coordinator outside Slurm, `sweep.sbatch --coordinator URL`,
#   6. automatic allocations (`sweep coordinator --slurm-alloc FILE`, no hand-submitted worker): a
#      campaign of mixed short and long points (40 of 0.3 s, 8 of 15 s) with allocations of one
#      core and a one-minute time limit, two in flight at most, far shorter than the campaign:
#      allocations appear, every point is done exactly once and before the time limit of the
#      allocation that ran it (no lease lost, no job run twice), more allocations than may be in
#      flight take over one after the other, and once the queue is empty they end and no new one
#      is submitted; `sweep workers` and `sweep status` show them,
#   7. a broken sbatch argument (a partition that does not exist): the error is shown by `sweep
#      status` and `sweep workers`, sbatch is tried once in 12 s (not looped), nothing runs; and a
#      coordinator that cannot find sbatch refuses to start, writing nothing.
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
    # The test's coordinators of steps 5 to 7, if they are still up.
    for pid in "$work"/login.pid "$work"/coordinator-*.pid; do
        if [[ -f $pid ]]; then kill "$(cat "$pid")" 2>/dev/null || true; fi
    done
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

# 6. Automatic allocations: the coordinator submits sweep.sbatch's workers-only form itself, as
#    the work asks; no worker is submitted by hand.
printf 'name = "auto"\n[[noop]]\ncount = 40\nduration_ms = 300\n[[noop]]\ncount = 8\nduration_ms = 15000\n' \
    >"$shared/auto.toml"
printf '%s\n' 'time_limit = "1:00"' 'cores = 1' 'max_in_flight = 2' 'idle_timeout_s = 5' \
    'stop_margin_s = 15' 'check_every_s = 2' "directory = \"$shared/allocations\"" >"$shared/alloc.toml"
# start_coordinator NAME DB ALLOCATION_FILE: a coordinator that allocates; its URL in $url.
start_coordinator() {
    sweep coordinator --listen 127.0.0.1:0 --db "$2" --token-file "$shared/sweep/token" \
        --lease-secs 5 --slurm-alloc "$3" >"$work/$1.out" 2>"$work/$1.log" &
    echo $! >"$work/coordinator-$1.pid"
    for _ in $(seq 100); do grep -q '^listening on' "$work/$1.out" && break; sleep 0.1; done
    url=http://$(sed -n 's/^listening on //p' "$work/$1.out")
}
stop_coordinator() { kill "$(cat "$work/coordinator-$1.pid")" && rm "$work/coordinator-$1.pid"; }
# Allocations of the allocator that Slurm still has.
in_flight() { squeue --noheader --name=sweep-workers --states=PENDING,CONFIGURING,RUNNING,COMPLETING --format=%i | wc -l; }
db=$shared/auto.db
start_coordinator auto "$db" "$shared/alloc.toml"
K=(--coordinator "$url" --token-file "$shared/sweep/token")
submitted_at=$(date +%s)
sweep submit "$shared/auto.toml" "${K[@]}" >/dev/null 2>&1
peak=0 shown=0
for _ in $(seq 600); do
    now_in_flight=$(in_flight)
    peak=$((now_in_flight > peak ? now_in_flight : peak))
    left=$(q "SELECT count(*) FROM jobs WHERE state <> 'done'")
    if [[ $shown -eq 0 && $now_in_flight -gt 0 ]]; then
        shown=1
        say "allocations appear: $now_in_flight in flight $(($(date +%s) - submitted_at)) s after the submission"
        sweep workers "${K[@]}" | sed -n '/^allocation/,$p'
    fi
    open=$(q "SELECT count(*) FROM allocations WHERE state IN ('pending', 'running')")
    [[ $left -eq 0 && $now_in_flight -eq 0 && $open -eq 0 ]] && break
    sleep 0.5
done
if [[ $left -ne 0 || $now_in_flight -ne 0 || $open -ne 0 ]]; then
    echo "FAILED: $left points left, $now_in_flight allocations in flight, $open open"; cat "$work/auto.log"; exit 1
fi
say "every point done and every allocation ended $(($(date +%s) - submitted_at)) s after the submission; at most $peak in flight at once (squeue)"
sweep workers "${K[@]}"
sweep status "${K[@]}"
check "every point done" "SELECT count(*) FROM jobs WHERE state = 'done'" 48
check "every point run once (one attempt each: no lease lost, nothing run twice)" "SELECT count(*) FROM jobs WHERE attempts <> 1" 0
check "no attempt failed or expired" "SELECT count(*) FROM job_failures" 0
check "no report refused as late" "SELECT count(*) FROM late_reports" 0
check "each point's results from one worker" \
    "SELECT count(*) FROM (SELECT job_id FROM results GROUP BY job_id HAVING count(DISTINCT worker_id) > 1)" 0
check "every point run by a worker of an allocation" \
    "SELECT count(*) FROM jobs AS j JOIN workers AS w ON w.id = j.lease_owner WHERE w.allocation IS NULL" 0
check "every allocation ended by itself (none failed, none hit its time limit)" \
    "SELECT count(*) FROM allocations WHERE state <> 'ended' OR reason <> 'COMPLETED'" 0
check "more allocations than may be in flight: new ones took over" "SELECT count(*) > 2 FROM allocations" 1
check "never more than 2 in flight (the allocator's records)" \
    "SELECT max(n) <= 2 FROM (SELECT count(*) AS n FROM allocations AS a JOIN allocations AS b
         ON b.submitted_at <= a.submitted_at AND a.submitted_at < b.ended_at GROUP BY a.id)" 1
check "every allocation ran points" \
    "SELECT count(*) FROM allocations AS a WHERE NOT EXISTS (SELECT 1 FROM workers AS w
         JOIN jobs AS j ON j.lease_owner = w.id WHERE w.allocation = a.external_id)" 0
check "every point finished before the time limit of the allocation that ran it" \
    "SELECT count(*) FROM jobs AS j JOIN workers AS w ON w.id = j.lease_owner
         JOIN allocations AS a ON a.external_id = w.allocation
     WHERE j.finished_at >= a.started_at + a.time_limit_s" 0
say "closest to a time limit, a point finished $(q "SELECT printf('%.1f', min(a.started_at + a.time_limit_s - j.finished_at)) FROM jobs AS j JOIN workers AS w ON w.id = j.lease_owner JOIN allocations AS a ON a.external_id = w.allocation") s before it (the workers stop 15 s before)"
say "why the workers stopped: $(sed -n 's/^sweep worker: stopping: //p' "$shared"/allocations/slurm-*.out | sed 's/[0-9][0-9.]* s/N s/g' | sort | uniq -c | tr -s ' ' | paste -sd ';' -)"
grep -q 'no job for' "$shared"/allocations/slurm-*.out || { echo "FAILED: no worker stopped for its idle timeout"; exit 1; }
allocations_then=$(q "SELECT count(*) FROM allocations")
sleep 8
check "with the queue empty, no allocation is submitted (8 s, 4 checks)" "SELECT count(*) FROM allocations" "$allocations_then"
stop_coordinator auto

# 7. A broken sbatch argument: shown, and not retried in a loop.
sed 's/^cores = 1$/cores = 1\npartition = "nope"/' "$shared/alloc.toml" >"$shared/broken.toml"
refused_before=$(grep -c 'Invalid partition name specified' "$work/slurmctld.log" || true)
db=$shared/broken.db
start_coordinator broken "$db" "$shared/broken.toml"
K=(--coordinator "$url" --token-file "$shared/sweep/token")
printf 'name = "broken"\n[[noop]]\ncount = 4\nduration_ms = 100\n' >"$shared/broken-plan.toml"
sweep submit "$shared/broken-plan.toml" "${K[@]}" >/dev/null 2>&1
sleep 12
refused=$(($(grep -c 'Invalid partition name specified' "$work/slurmctld.log" || true) - refused_before))
sweep status "${K[@]}" | tee "$work/broken.status"
sweep workers "${K[@]}" | tee "$work/broken.workers"
[[ $refused -eq 1 ]] || { echo "FAILED: slurmctld refused $refused submissions in 12 s, expected one"; exit 1; }
say "ok: slurmctld saw one submission in 12 s (6 checks of the allocator): it backs off, it does not loop"
grep -q 'backing off: 1 failures in a row' "$work/broken.status" || { echo "FAILED: sweep status does not say it backs off"; exit 1; }
grep -q 'failed allocation .*Invalid partition name specified' "$work/broken.status" || { echo "FAILED: sweep status does not show sbatch's error"; exit 1; }
grep -q 'failed .*sbatch failed: .*Invalid partition name specified' "$work/broken.workers" || { echo "FAILED: sweep workers does not show sbatch's error"; exit 1; }
say "ok: sweep status and sweep workers show sbatch's error"
check "nothing ran" "SELECT count(*) FROM jobs WHERE state = 'queued'" 4
stop_coordinator broken
# No sbatch on PATH: refused before anything is written.
if out=$(PATH=/nonexistent "$shared/bin/sweep" coordinator --listen 127.0.0.1:0 --db "$shared/none.db" \
    --slurm-alloc "$shared/alloc.toml" 2>&1); then
    echo "FAILED: a coordinator started without sbatch"; exit 1
fi
echo "$out"
[[ $out == *"cannot find sbatch, squeue, scancel on PATH"* && ! -e $shared/none.db ]] || { echo "FAILED: $out"; exit 1; }
say "ok: without sbatch the coordinator refuses to start, in one line, and writes no database"

say "passed in $(($(date +%s) - started)) s"
