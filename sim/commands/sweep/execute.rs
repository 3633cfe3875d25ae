//! Running a sweep's episodes: batch by batch (the surveys before the planners whose budgets
//! they set), skipping complete episodes, each episode a `splatloop run` child process whose
//! output goes to its log. Locally N run at a time; with Ray each is a task on the cluster
//! (`ray_driver.py`). Either way a finished episode is settled here: complete, or failed with
//! its error recorded beside its folder, and the others go on.

use super::pace::Pace;
use super::spec::{Episode, EpisodeState, Sweep};
use crate::episode::StopRequest;
use crate::error::{Result, SimError};
use std::io::BufRead;
use std::path::{Path, PathBuf};
use std::process::{Command, Stdio};
use std::sync::atomic::{AtomicUsize, Ordering};
use std::time::Instant;

/// The Ray driver the sweep runs with the cluster's Python.
const RAY_DRIVER: &str = include_str!("ray_driver.py");

/// Lines of an episode's log kept in its failure record.
const LOG_TAIL_LINES: usize = 20;

/// Where the episodes run.
#[derive(Debug, Clone)]
pub enum Backend {
    /// Child processes on this machine, `jobs` at a time.
    Local {
        /// Episodes at once.
        jobs: usize,
    },
    /// One Ray task per episode, running the binary on a worker (a filesystem shared by the
    /// workers is assumed: the binary, the worlds and the output folder at the same paths).
    Ray {
        /// The cluster (`ray start --head` prints it); none starts a local Ray for the sweep.
        address: Option<String>,
        /// A Python with Ray installed.
        python: PathBuf,
        /// Episodes in flight at most (none: as many as the cluster schedules).
        jobs: Option<usize>,
        /// CPUs Ray reserves for each episode.
        cpus_per_episode: f64,
    },
}

/// The state of a sweep as it runs, for a progress display.
#[derive(Debug, Clone, Copy, Default)]
pub struct SweepProgress {
    /// Episodes in the sweep.
    pub total: usize,
    /// Complete, earlier runs included.
    pub complete: usize,
    /// Running now.
    pub running: usize,
    /// Failed in this run.
    pub failed: usize,
    /// Wall seconds to the end, from this run's finished episodes (`pace`; none before one
    /// has finished).
    pub eta_seconds: Option<f64>,
}

/// What a sweep run did.
#[derive(Debug, Clone, Default)]
pub struct SweepReport {
    /// Episodes in the sweep.
    pub total: usize,
    /// Complete before this run, so not run again.
    pub skipped: usize,
    /// Run by this run.
    pub ran: usize,
    /// Failed in this run: episode index and error.
    pub failed: Vec<(usize, String)>,
    /// The signal's exit code when one stopped the sweep (no episode started after it; the
    /// running ones were passed the signal and wrote their interrupted folders).
    pub stopped: Option<usize>,
}

/// One episode to run: its index and the command line of its `splatloop run`.
#[derive(Debug, Clone, serde::Serialize)]
struct Task {
    index: usize,
    binary: PathBuf,
    args: Vec<String>,
    log: PathBuf,
    cwd: PathBuf,
}

/// What a backend reports about a task.
enum Event {
    /// The episode's index.
    Started(usize),
    /// The exit code (none when killed by a signal), or why the process could not run.
    Finished(usize, std::result::Result<Option<i32>, String>),
}

/// Runs every episode of `sweep` that is not complete, with `binary` as `splatloop`.
/// A signal in `stop` starts no new episode and is passed on to the running ones.
pub fn run_sweep(
    sweep: &Sweep,
    backend: &Backend,
    binary: &Path,
    stop: &StopRequest,
    on_progress: &mut dyn FnMut(&SweepProgress),
) -> Result<SweepReport> {
    let _lock = lock_sweep(sweep)?;
    let started = Instant::now();
    let mut report = SweepReport {
        total: sweep.episodes.len(),
        ..SweepReport::default()
    };
    let mut progress = SweepProgress {
        total: sweep.episodes.len(),
        ..SweepProgress::default()
    };
    // Read once: batches are disjoint, so an episode's state changes only when its own
    // batch runs it.
    let done: Vec<bool> = sweep
        .episodes
        .iter()
        .map(|e| matches!(sweep.state(e), EpisodeState::Complete { .. }))
        .collect();
    report.skipped = done.iter().filter(|d| **d).count();
    let mut freed = 0;
    for (e, _) in sweep.episodes.iter().zip(&done).filter(|(_, d)| **d) {
        freed += drop_frames_unless_kept(sweep, e)?;
    }
    if freed > 0 {
        tracing::info!(
            "--keep-frames false: removed {:.2} GB of images from the episodes already complete",
            freed as f64 / 1e9
        );
    }
    progress.complete = report.skipped;
    on_progress(&progress);
    let mut pace = Pace::default();
    for (number, batch) in sweep.batches().into_iter().enumerate() {
        if stop.requested().is_some() {
            break;
        }
        if let Some(factor) = sweep.factor().filter(|_| number > 0) {
            // The surveys have run: say which set a budget from their cap, not their route.
            for survey in sweep.cut_short_surveys() {
                tracing::warn!(
                    "the survey in {} (seed {}) ended before its route did, on the survey budget; \
                     the planners there get {} x that budget, not the survey's time: rerun the \
                     sweep in a new folder with a larger --survey-budget",
                    survey.world_name,
                    survey.seed,
                    factor,
                );
            }
        }
        let mut tasks = Vec::new();
        for &i in batch.iter().filter(|&&i| !done[i]) {
            let e = &sweep.episodes[i];
            match task(sweep, e.index, binary) {
                Ok(t) => tasks.push(t),
                Err(error) => {
                    // A planner whose survey failed cannot have its budget: that is its failure.
                    let text = error.to_string();
                    record_failure(sweep, e.index, &text)?;
                    report.failed.push((e.index, text));
                    progress.failed += 1;
                }
            }
        }
        if tasks.is_empty() {
            continue;
        }
        let mut on_event = |event: Event| -> Result<()> {
            match event {
                Event::Started(i) => {
                    progress.running += 1;
                    pace.started(i, started.elapsed().as_secs_f64());
                }
                Event::Finished(i, outcome) => {
                    progress.running = progress.running.saturating_sub(1);
                    pace.finished(i, started.elapsed().as_secs_f64());
                    report.ran += 1;
                    match settle(sweep, i, outcome)? {
                        None => progress.complete += 1,
                        Some(error) => {
                            report.failed.push((i, error));
                            progress.failed += 1;
                        }
                    }
                }
            }
            let queued = progress
                .total
                .saturating_sub(progress.complete + progress.failed + progress.running);
            progress.eta_seconds = pace.seconds_left(started.elapsed().as_secs_f64(), queued);
            on_progress(&progress);
            Ok(())
        };
        match backend {
            Backend::Local { jobs } => execute_local(sweep, &tasks, *jobs, stop, &mut on_event)?,
            Backend::Ray {
                address,
                python,
                jobs,
                cpus_per_episode,
            } => execute_ray(
                sweep,
                number,
                &tasks,
                RayOptions {
                    address: address.as_deref(),
                    python,
                    jobs: *jobs,
                    cpus_per_episode: *cpus_per_episode,
                },
                stop,
                &mut on_event,
            )?,
        }
    }
    report.stopped = stop.requested();
    Ok(report)
}

/// Takes OUT/.sweep.lock for the sweep's life (the kernel drops it if the process dies), so
/// two sweeps never run the same episodes at once; `sweep episode` takes it shared, so the
/// tasks of a Slurm array run side by side but never beside a whole sweep.
fn lock_sweep(sweep: &Sweep) -> Result<std::fs::File> {
    take_sweep_lock(sweep, false)
}

fn take_sweep_lock(sweep: &Sweep, shared: bool) -> Result<std::fs::File> {
    let path = sweep.out.join(".sweep.lock");
    let file = std::fs::File::create(&path).map_err(|e| SimError::io("cannot create", &path, e))?;
    let taken = if shared {
        file.try_lock_shared()
    } else {
        file.try_lock()
    };
    match taken {
        Ok(()) => Ok(file),
        Err(std::fs::TryLockError::WouldBlock) => Err(SimError::InvalidArgument {
            what: "--out",
            detail: if shared {
                format!(
                    "a sweep is running in {}: it runs this episode itself; wait for it, or stop it first",
                    sweep.out.display()
                )
            } else {
                format!(
                    "another sweep (or a `sweep episode` task) is running in {}; wait for it, or stop it and rerun",
                    sweep.out.display()
                )
            },
        }),
        Err(std::fs::TryLockError::Error(e)) => Err(SimError::io("cannot lock", path, e)),
    }
}

/// Takes the lock of one episode (`.SEED.task.lock` beside its log; `.SEED.lock` is its
/// run's own folder lock) before its log is opened, so two processes never run one episode
/// or write one log.
fn lock_episode(sweep: &Sweep, index: usize) -> Result<std::fs::File> {
    let log = sweep.log(&sweep.episodes[index]);
    let name = log
        .file_stem()
        .map_or_else(|| format!("{index}"), |s| s.to_string_lossy().into_owned());
    let path = log.with_file_name(format!(".{name}.task.lock"));
    if let Some(parent) = path.parent() {
        std::fs::create_dir_all(parent).map_err(|e| SimError::io("cannot create", parent, e))?;
    }
    let file = std::fs::File::create(&path).map_err(|e| SimError::io("cannot create", &path, e))?;
    match file.try_lock() {
        Ok(()) => Ok(file),
        Err(std::fs::TryLockError::WouldBlock) => Err(SimError::SweepEpisode {
            index,
            detail: "another process is running this episode; wait for it".into(),
        }),
        Err(std::fs::TryLockError::Error(e)) => Err(SimError::io("cannot lock", path, e)),
    }
}

/// Runs episode `index` of `sweep` here and settles it: the per-task command of a Slurm
/// array. `Ok(None)` when it is complete (already, or now), else its error.
pub fn run_one(
    sweep: &Sweep,
    index: usize,
    binary: &Path,
    stop: &StopRequest,
) -> Result<Option<String>> {
    let _sweep_lock = take_sweep_lock(sweep, true)?;
    if sweep.episodes.get(index).is_none() {
        return Err(SimError::SweepEpisode {
            index,
            detail: format!(
                "no such episode: the sweep has {} (0..{})",
                sweep.episodes.len(),
                sweep.episodes.len().saturating_sub(1)
            ),
        });
    }
    if matches!(
        sweep.state(&sweep.episodes[index]),
        EpisodeState::Complete { .. }
    ) {
        return Ok(None);
    }
    let _episode_lock = lock_episode(sweep, index)?;
    let task = match task(sweep, index, binary) {
        Ok(t) => t,
        Err(error) => {
            record_failure(sweep, index, &error.to_string())?;
            return Err(error);
        }
    };
    let outcome = run_child(&task, stop);
    settle(sweep, index, outcome)
}

/// The episode's task; its log's folder is made here, so a Ray worker can open the log.
fn task(sweep: &Sweep, index: usize, binary: &Path) -> Result<Task> {
    let e = &sweep.episodes[index];
    let log = sweep.log(e);
    if let Some(parent) = log.parent() {
        std::fs::create_dir_all(parent).map_err(|e| SimError::io("cannot create", parent, e))?;
    }
    Ok(Task {
        index,
        binary: binary.to_path_buf(),
        args: sweep.command(e)?,
        log,
        cwd: std::env::current_dir().map_err(|e| SimError::io("cannot read", ".", e))?,
    })
}

/// Looks at a finished episode: `None` when complete (an earlier failure record is removed),
/// else its error, which is recorded beside its folder.
fn settle(
    sweep: &Sweep,
    index: usize,
    outcome: std::result::Result<Option<i32>, String>,
) -> Result<Option<String>> {
    let e = &sweep.episodes[index];
    let state = sweep.state(e);
    if let (EpisodeState::Complete { .. }, Ok(Some(0))) = (&state, &outcome) {
        drop_frames_unless_kept(sweep, e)?;
        let stale = sweep.failure_file(e);
        if stale.exists() {
            std::fs::remove_file(&stale)
                .map_err(|err| SimError::io("cannot remove", stale, err))?;
        }
        return Ok(None);
    }
    let how = match outcome {
        Ok(Some(code)) => format!("splatloop run exited with status {code}"),
        Ok(None) => "splatloop run was killed by a signal".to_string(),
        Err(why) => why,
    };
    let ended = match state {
        EpisodeState::Failed { error } => format!(" ({error})"),
        _ => String::new(),
    };
    let log = sweep.log(e);
    let tail = log_tail(&log);
    let error = format!(
        "{how}{ended}; its log is {}{}",
        log.display(),
        if tail.is_empty() {
            String::new()
        } else {
            format!(", ending:\n{tail}")
        }
    );
    record_failure(sweep, index, &error)?;
    Ok(Some(error))
}

/// Removes a complete episode's images when the sweep keeps none (`--keep-frames false`);
/// the bytes freed.
fn drop_frames_unless_kept(sweep: &Sweep, e: &Episode) -> Result<u64> {
    if sweep.spec.keep_frames {
        return Ok(0);
    }
    crate::dataset::remove_frames(&sweep.folder(e))
}

fn record_failure(sweep: &Sweep, index: usize, error: &str) -> Result<()> {
    let path = sweep.failure_file(&sweep.episodes[index]);
    if let Some(parent) = path.parent() {
        std::fs::create_dir_all(parent).map_err(|e| SimError::io("cannot create", parent, e))?;
    }
    std::fs::write(&path, format!("{error}\n")).map_err(|e| SimError::io("cannot write", path, e))
}

fn log_tail(log: &Path) -> String {
    let text = std::fs::read_to_string(log).unwrap_or_default();
    let lines: Vec<&str> = text.lines().collect();
    lines[lines.len().saturating_sub(LOG_TAIL_LINES)..].join("\n")
}

/// Runs a task's command with its output into its log, passing a signal in `stop` on to it.
fn run_child(task: &Task, stop: &StopRequest) -> std::result::Result<Option<i32>, String> {
    // `task` made the log's folder.
    let open = || -> std::io::Result<(std::fs::File, std::fs::File)> {
        let log = std::fs::File::create(&task.log)?;
        let copy = log.try_clone()?;
        Ok((log, copy))
    };
    let (out, err) = open().map_err(|e| format!("cannot write {}: {e}", task.log.display()))?;
    let mut child = Command::new(&task.binary)
        .args(&task.args)
        .current_dir(&task.cwd)
        .stdin(Stdio::null())
        .stdout(out)
        .stderr(err)
        .spawn()
        .map_err(|e| format!("cannot start {}: {e}", task.binary.display()))?;
    let mut passed_on = false;
    loop {
        match child.try_wait() {
            Ok(Some(status)) => return Ok(status.code()),
            Ok(None) => {}
            Err(e) => return Err(format!("cannot wait for {}: {e}", task.binary.display())),
        }
        if let (Some(code), false) = (stop.requested(), passed_on) {
            pass_signal_on(&child, code);
            passed_on = true;
        }
        std::thread::sleep(std::time::Duration::from_millis(100));
    }
}

/// Sends a child the signal behind a stop request's exit code (SIGINT or SIGTERM).
fn pass_signal_on(child: &std::process::Child, code: usize) {
    use rustix::process::{kill_process, Pid, Signal};
    let signal = if code == StopRequest::SIGTERM {
        Signal::TERM
    } else {
        Signal::INT
    };
    // The child may have just ended: then there is no one to tell.
    let _ = kill_process(Pid::from_child(child), signal);
}

fn execute_local(
    sweep: &Sweep,
    tasks: &[Task],
    jobs: usize,
    stop: &StopRequest,
    on_event: &mut dyn FnMut(Event) -> Result<()>,
) -> Result<()> {
    let next = AtomicUsize::new(0);
    let (sender, events) = std::sync::mpsc::channel();
    std::thread::scope(|scope| {
        for _ in 0..jobs.clamp(1, tasks.len().max(1)) {
            let sender = sender.clone();
            let next = &next;
            scope.spawn(move || loop {
                if stop.requested().is_some() {
                    break;
                }
                let k = next.fetch_add(1, Ordering::Relaxed);
                let Some(task) = tasks.get(k) else { break };
                let _ = sender.send(Event::Started(task.index));
                let outcome = match lock_episode(sweep, task.index) {
                    Ok(_lock) => run_child(task, stop),
                    Err(busy) => Err(busy.to_string()),
                };
                let _ = sender.send(Event::Finished(task.index, outcome));
            });
        }
        drop(sender);
        // A failed bookkeeping write ends the sweep once the running episodes are done.
        let mut first_error = None;
        for event in events {
            if let Err(e) = on_event(event) {
                next.store(tasks.len(), Ordering::Relaxed);
                first_error.get_or_insert(e);
            }
        }
        first_error.map_or(Ok(()), Err)
    })
}

struct RayOptions<'a> {
    address: Option<&'a str>,
    python: &'a Path,
    jobs: Option<usize>,
    cpus_per_episode: f64,
}

/// Hands the tasks to the Ray driver and turns its report lines (`started I`, `finished I
/// CODE`, `failed I REASON`) into events.
fn execute_ray(
    sweep: &Sweep,
    batch: usize,
    tasks: &[Task],
    options: RayOptions,
    stop: &StopRequest,
    on_event: &mut dyn FnMut(Event) -> Result<()>,
) -> Result<()> {
    let dir = sweep.out.join(".ray");
    std::fs::create_dir_all(&dir).map_err(|e| SimError::io("cannot create", &dir, e))?;
    let driver = dir.join("ray_driver.py");
    std::fs::write(&driver, RAY_DRIVER).map_err(|e| SimError::io("cannot write", &driver, e))?;
    let tasks_file = dir.join(format!("batch-{batch}.json"));
    crate::dataset::write_json(&tasks_file, &tasks)?;
    let driver_log = dir.join("driver.log");
    let log = std::fs::File::create(&driver_log)
        .map_err(|e| SimError::io("cannot write", &driver_log, e))?;
    let mut command = Command::new(options.python);
    command
        .arg(&driver)
        .arg("--tasks")
        .arg(&tasks_file)
        .arg("--cpus-per-episode")
        .arg(options.cpus_per_episode.to_string())
        .stdin(Stdio::null())
        .stdout(Stdio::piped())
        .stderr(log);
    if let Some(address) = options.address {
        command.arg("--address").arg(address);
    }
    if let Some(jobs) = options.jobs {
        command.arg("--max-in-flight").arg(jobs.to_string());
    }
    let mut child = command
        .spawn()
        .map_err(|e| SimError::io("cannot start the Ray driver with", options.python, e))?;
    let stdout = child.stdout.take().ok_or_else(|| {
        SimError::io(
            "cannot read the Ray driver's output of",
            &driver,
            std::io::Error::other("no pipe"),
        )
    })?;
    // A signal to the sweep is passed on to the driver, whose tasks then end.
    let reading = std::sync::atomic::AtomicBool::new(true);
    let first_error = std::thread::scope(|scope| -> Result<Option<SimError>> {
        scope.spawn(|| {
            while reading.load(Ordering::Relaxed) {
                if let Some(code) = stop.requested() {
                    pass_signal_on(&child, code);
                    break;
                }
                std::thread::sleep(std::time::Duration::from_millis(100));
            }
        });
        let mut first_error = None;
        for line in std::io::BufReader::new(stdout).lines() {
            let line = match line {
                Ok(line) => line,
                Err(e) => {
                    reading.store(false, Ordering::Relaxed);
                    return Err(SimError::io("cannot read the output of", &driver, e));
                }
            };
            let words: Vec<&str> = line.splitn(3, ' ').collect();
            let index = words.get(1).and_then(|w| w.parse::<usize>().ok());
            let event = match (words.first().copied(), index) {
                (Some("started"), Some(i)) => Event::Started(i),
                (Some("finished"), Some(i)) => {
                    let code = words.get(2).and_then(|w| w.trim().parse::<i32>().ok());
                    // Python reports a process killed by signal N as -N.
                    Event::Finished(i, Ok(code.filter(|&c| c >= 0)))
                }
                (Some("failed"), Some(i)) => Event::Finished(
                    i,
                    Err(format!(
                        "the Ray task failed: {}",
                        words.get(2).copied().unwrap_or("")
                    )),
                ),
                _ => continue,
            };
            if let Err(e) = on_event(event) {
                first_error.get_or_insert(e);
            }
        }
        reading.store(false, Ordering::Relaxed);
        Ok(first_error)
    })?;
    let status = child
        .wait()
        .map_err(|e| SimError::io("cannot wait for the Ray driver", &driver, e))?;
    if let Some(e) = first_error {
        return Err(e);
    }
    if stop.requested().is_some() {
        // Stopped on purpose: the episodes it ran are settled; the rest are not run.
        return Ok(());
    }
    if !status.success() {
        let mut tail = log_tail(&driver_log);
        if tail.is_empty() {
            tail = "(no output)".into();
        }
        return Err(SimError::io(
            "the Ray driver failed",
            &driver,
            std::io::Error::other(format!(
                "{status}; is Ray installed for {} (scripts/setup.sh installs it into .venv)? Its log {} ends:\n{tail}",
                options.python.display(),
                driver_log.display()
            )),
        ));
    }
    Ok(())
}
