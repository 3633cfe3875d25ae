"""splatloop's Ray driver: runs a batch of sweep episodes as Ray tasks.

`splatloop sweep --backend ray` writes this file and a tasks file into the sweep's .ray/
folder and runs it with a Python that has Ray. Each task runs one `splatloop run` on a worker
(the binary, the worlds and the output folder at the same paths there: a shared filesystem),
its output into the episode's log. Report lines on stdout, one per event, are what the Rust
side reads: `started I`, `finished I EXIT_CODE`, `failed I REASON`.
"""

import argparse
import json
import re
import subprocess
import sys


def main():
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--tasks", required=True, help="JSON list of tasks")
    parser.add_argument("--address", default=None, help="Ray cluster; none starts a local Ray")
    parser.add_argument("--cpus-per-episode", type=float, default=1.0)
    parser.add_argument("--max-in-flight", type=int, default=0, help="0: no limit")
    options = parser.parse_args()
    try:
        import ray
    except ImportError as e:
        print(f"Ray is not installed for {sys.executable}: {e}; run scripts/setup.sh "
              "(it installs Ray into .venv) or pass --ray-python", file=sys.stderr)
        return 3
    with open(options.tasks) as f:
        tasks = json.load(f)

    @ray.remote(num_cpus=options.cpus_per_episode, max_retries=0)
    def episode(binary, args, log, cwd):
        with open(log, "wb") as out:
            return subprocess.run([binary] + args, stdout=out, stderr=subprocess.STDOUT,
                                  stdin=subprocess.DEVNULL, cwd=cwd).returncode

    ray.init(address=options.address, include_dashboard=False, log_to_driver=False,
             configure_logging=False)
    queue = list(tasks)
    pending = {}
    while queue or pending:
        while queue and (options.max_in_flight <= 0 or len(pending) < options.max_in_flight):
            task = queue.pop(0)
            ref = episode.remote(task["binary"], task["args"], task["log"], task["cwd"])
            pending[ref] = task["index"]
            print(f"started {task['index']}", flush=True)
        done, _ = ray.wait(list(pending), num_returns=1)
        for ref in done:
            index = pending.pop(ref)
            try:
                print(f"finished {index} {ray.get(ref)}", flush=True)
            except Exception as e:  # a worker lost, a task that raised: that episode failed
                reason = " ".join(re.sub(r"\x1b\[[0-9;]*m", "", str(e)).split())
                print(f"failed {index} {reason}", flush=True)
    ray.shutdown()
    return 0


if __name__ == "__main__":
    sys.exit(main())
