//! `splatloop sweep`: a row per episode that matches the episode's own metrics.json, the
//! survey-factor budget, the summary's numbers from the table, charts with their points; a
//! rerun runs nothing and a changed one is refused; a killed sweep reruns only what did not
//! finish; Ray gives the local results; each Slurm array task runs exactly its episode.

use crate::support::repo_path;
use splatloop::sweep::results::TIMING_COLUMNS;
use std::collections::BTreeMap;
use std::path::{Path, PathBuf};
use std::process::{Command, Output, Stdio};
use std::time::{Duration, Instant};

/// Small, fast episodes: the CPU engine, a 160x120 camera, 20 hidden views, no latency.
const OPTIONS: [&str; 10] = [
    "--latency",
    "none",
    "--engine",
    "cpu",
    "--width",
    "160",
    "--height",
    "120",
    "--test-views",
    "20",
];

fn sweep_command(out: &Path, args: &[&str]) -> Command {
    let mut command = Command::new(env!("CARGO_BIN_EXE_splatloop"));
    command
        .current_dir(repo_path(""))
        .args(["sweep", "--worlds", "worlds/room.xml", "--out"])
        .arg(out)
        .args(OPTIONS)
        .args(args);
    command
}

fn run_sweep(out: &Path, args: &[&str]) -> Output {
    let output = sweep_command(out, args).output().expect("sweep runs");
    assert!(
        output.status.success(),
        "sweep failed: {}\n{}",
        String::from_utf8_lossy(&output.stdout),
        String::from_utf8_lossy(&output.stderr)
    );
    output
}

fn rows(out: &Path) -> Vec<BTreeMap<String, String>> {
    let mut reader = csv::Reader::from_path(out.join("results.csv")).expect("results.csv");
    reader
        .deserialize()
        .map(|r| r.expect("a row"))
        .collect::<Vec<BTreeMap<String, String>>>()
}

fn json(path: &Path) -> serde_json::Value {
    serde_json::from_slice(&std::fs::read(path).expect("file")).expect("json")
}

fn episode(out: &Path, planner: &str, seed: u64) -> PathBuf {
    out.join("room").join(planner).join(seed.to_string())
}

fn modified(path: &Path) -> std::time::SystemTime {
    std::fs::metadata(path)
        .and_then(|m| m.modified())
        .expect("mtime")
}

fn number(row: &BTreeMap<String, String>, column: &str) -> f64 {
    row[column]
        .parse()
        .unwrap_or_else(|_| panic!("{column} is a number"))
}

/// Pixels of `colour` in a PNG.
fn pixels_of(path: &Path, colour: [u8; 3]) -> usize {
    let decoder = png::Decoder::new(std::fs::File::open(path).expect("png"));
    let mut reader = decoder.read_info().expect("png header");
    let mut buffer = vec![0; reader.output_buffer_size()];
    let info = reader.next_frame(&mut buffer).expect("png frame");
    assert_eq!(info.color_type, png::ColorType::Rgb);
    buffer[..info.buffer_size()]
        .chunks(3)
        .filter(|p| *p == colour)
        .count()
}

#[test]
fn a_sweep_gathers_every_episode_and_a_rerun_runs_nothing() {
    let dir = tempfile::tempdir().expect("tempdir");
    let out = dir.path().join("sweep");
    let args = [
        "--planners",
        "survey,fbe",
        "--seeds",
        "1..2",
        "--budget-survey-factor",
        "0.5",
        "--survey-budget",
        "10",
        "--jobs",
        "2",
    ];
    run_sweep(&out, &args);

    let table = rows(&out);
    assert_eq!(table.len(), 4, "2 planners x 2 seeds");
    let mut seen: Vec<(String, String)> = table
        .iter()
        .map(|r| (r["planner"].clone(), r["seed"].clone()))
        .collect();
    seen.sort();
    assert_eq!(
        seen,
        [("fbe", "1"), ("fbe", "2"), ("survey", "1"), ("survey", "2")]
            .map(|(p, s)| (p.to_string(), s.to_string()))
    );
    for row in &table {
        assert_eq!(row["status"], "complete", "{row:?}");
        let seed: u64 = row["seed"].parse().expect("seed");
        let folder = episode(&out, &row["planner"], seed);
        let metrics = json(&folder.join("metrics.json"));
        // Every figure is the episode's own.
        for (column, value) in [
            ("evaluation.coverage", &metrics["evaluation"]["coverage"]),
            ("evaluation.psnr", &metrics["evaluation"]["psnr"]),
            ("path_length", &metrics["path_length"]),
            ("simulated_seconds", &metrics["simulated_seconds"]),
        ] {
            assert_eq!(
                number(row, column),
                value.as_f64().expect("number"),
                "{column}"
            );
        }
        // The run options reached the episode.
        let config = &json(&folder.join("episode.json"))["config"];
        assert_eq!(config["sensor"]["width"], 160);
        assert_eq!(config["latency"], "none");
        // The coverage series ends at the evaluation's coverage, in time order.
        let series = metrics["coverage_over_time"].as_array().expect("series");
        assert!(series.len() >= 2, "a point every 10 s and one at the end");
        let times: Vec<f64> = series.iter().map(|p| p[0].as_f64().expect("t")).collect();
        assert!(times.windows(2).all(|w| w[0] <= w[1]), "{times:?}");
        assert_eq!(
            series.last().expect("last")[1].as_f64(),
            metrics["evaluation"]["coverage"].as_f64()
        );
    }
    // FBE got half the survey's time in the same world and seed.
    for seed in ["1", "2"] {
        let find = |p: &str| {
            table
                .iter()
                .find(|r| r["planner"] == p && r["seed"] == seed)
                .expect("row")
        };
        let survey_time = number(find("survey"), "simulated_seconds");
        assert!((number(find("fbe"), "budget") - 0.5 * survey_time).abs() < 1e-9);
        assert!((number(find("fbe"), "simulated_seconds") - 0.5 * survey_time).abs() < 0.01);
    }
    // The summary's means are the table's.
    let summary = std::fs::read_to_string(out.join("summary.md")).expect("summary.md");
    let fbe: Vec<f64> = table
        .iter()
        .filter(|r| r["planner"] == "fbe")
        .map(|r| number(r, "evaluation.coverage"))
        .collect();
    let mean = fbe.iter().sum::<f64>() / fbe.len() as f64;
    let line = summary
        .lines()
        .find(|l| l.starts_with("| evaluation.coverage |"))
        .expect("a coverage line");
    assert!(
        line.contains(&format!("| {mean:.3} ± ")),
        "{line} should hold fbe's mean {mean:.3}"
    );
    assert!(summary.contains(&format!(
        "| room | custom | fbe | 2 | {:.1} |",
        100.0 * mean
    )));
    assert!(summary.contains("## Against the survey"));
    // 10 s is too short for the room's survey route: the summary says whose budget is a cap's.
    for row in table.iter().filter(|r| r["planner"] == "survey") {
        assert_eq!(row["ended"], "budget", "{row:?}");
    }
    let cut_short = summary
        .lines()
        .find(|l| l.starts_with("**Surveys cut short"))
        .expect("the cut-short surveys named");
    assert!(
        cut_short.ends_with("room (seed 1), room (seed 2)."),
        "{cut_short}"
    );
    // The charts have their points: the first world's colour.
    assert!(pixels_of(&out.join("summary.png"), [31, 119, 180]) > 50);
    assert!(pixels_of(&out.join("coverage_over_time.png"), [31, 119, 180]) > 50);

    // A rerun of the finished sweep runs nothing and touches no episode.
    let written = || -> Vec<_> {
        table
            .iter()
            .map(|r| {
                modified(
                    &episode(&out, &r["planner"], r["seed"].parse().expect("seed"))
                        .join("metrics.json"),
                )
            })
            .collect()
    };
    let before = written();
    // By default every episode keeps its dataset; a rerun with --keep-frames false removes
    // the images from the episodes already complete, and nothing their numbers come from.
    let first = episode(&out, "fbe", 1);
    let images = std::fs::read_dir(first.join("rgb")).expect("rgb/").count();
    assert!(images > 10, "{images} images");
    let kept = [
        "metrics.json",
        "episode.json",
        "groundtruth.txt",
        "camera.json",
        "map.ply",
    ];
    let kept_bytes = |folder: &Path| -> Vec<Vec<u8>> {
        kept.iter()
            .map(|name| std::fs::read(folder.join(name)).expect(name))
            .collect()
    };
    let numbers_before = kept_bytes(&first);
    let mut dropping = args.to_vec();
    dropping.extend(["--keep-frames", "false"]);
    let again = run_sweep(&out, &dropping);
    let said = String::from_utf8_lossy(&again.stdout);
    assert!(said.contains("4 complete before, 0 run now"), "{said}");
    let after = written();
    assert_eq!(before, after);
    for row in &table {
        let folder = episode(&out, &row["planner"], row["seed"].parse().expect("seed"));
        for name in splatloop::dataset::FRAME_FILES {
            assert!(!folder.join(name).exists(), "{name} left in {folder:?}");
        }
    }
    assert_eq!(kept_bytes(&first), numbers_before);
    let refused = splatloop::dataset::Dataset::open(&first).expect_err("no images to read");
    assert!(
        refused.to_string().contains("--keep-frames false"),
        "{refused}"
    );
    assert_eq!(json(&out.join("sweep.json"))["keep_frames"], false);
    assert_eq!(
        rows(&out),
        table,
        "the results are the same without the images"
    );

    // Other settings in the same folder are refused, naming what changed.
    let mut changed = args;
    changed[3] = "1..3";
    let refused = sweep_command(&out, &changed).output().expect("runs");
    assert!(!refused.status.success());
    let stderr = String::from_utf8_lossy(&refused.stderr);
    assert!(
        stderr.contains("sweep.json") && stderr.contains("seeds were [1, 2]"),
        "{stderr}"
    );
}

#[test]
fn a_killed_sweep_reruns_only_the_episodes_that_did_not_finish() {
    let dir = tempfile::tempdir().expect("tempdir");
    let out = dir.path().join("sweep");
    let args = [
        "--planners",
        "fbe",
        "--seeds",
        "1..3",
        "--budget",
        "10",
        "--jobs",
        "1",
    ];
    let mut sweep = {
        use std::os::unix::process::CommandExt;
        sweep_command(&out, &args)
            .process_group(0)
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .spawn()
            .expect("sweep starts")
    };
    // Kill the sweep and its episode while the second episode is being written.
    let first = episode(&out, "fbe", 1).join("metrics.json");
    let second_staging = out.join("room/fbe/.2.partial/rgb");
    let started = Instant::now();
    while !(first.exists() && second_staging.exists()) {
        assert!(
            sweep.try_wait().expect("poll").is_none(),
            "the sweep ended first"
        );
        assert!(
            started.elapsed() < Duration::from_secs(300),
            "no progress in 300 s"
        );
        std::thread::sleep(Duration::from_millis(100));
    }
    let group = format!("-{}", sweep.id());
    let killed = Command::new("kill")
        .args(["-KILL", "--", &group])
        .status()
        .expect("kill");
    assert!(killed.success());
    let _ = sweep.wait();
    // The episode the sweep ran is in its group; a rerun right away would find its folder
    // still locked while it dies.
    while Command::new("kill")
        .args(["-0", "--", &group])
        .stderr(Stdio::null())
        .status()
        .expect("kill -0")
        .success()
    {
        std::thread::sleep(Duration::from_millis(50));
    }
    assert!(!episode(&out, "fbe", 2).join("metrics.json").exists());
    let first_written = modified(&first);

    let rerun = run_sweep(&out, &args);
    let said = String::from_utf8_lossy(&rerun.stdout);
    assert!(
        said.contains("1 complete before, 2 run now, 0 failed"),
        "{said}"
    );
    assert_eq!(
        modified(&first),
        first_written,
        "the finished episode is kept"
    );
    let table = rows(&out);
    assert_eq!(table.len(), 3);
    assert!(table.iter().all(|r| r["status"] == "complete"), "{table:?}");
}

/// A Ray head on a free port for one test, stopped when dropped.
struct RayHead {
    ray: PathBuf,
    address: String,
}

impl RayHead {
    fn start() -> RayHead {
        let ray = repo_path(".venv/bin/ray");
        assert!(
            ray.exists(),
            "{} is missing: scripts/setup.sh installs Ray into .venv",
            ray.display()
        );
        let port = std::net::TcpListener::bind("127.0.0.1:0")
            .and_then(|l| l.local_addr())
            .expect("a free port")
            .port();
        let status = Command::new(&ray)
            .args([
                "start",
                "--head",
                "--num-cpus",
                "2",
                "--disable-usage-stats",
            ])
            .args(["--include-dashboard", "false", "--port", &port.to_string()])
            .stdout(Stdio::null())
            .status()
            .expect("ray start");
        assert!(status.success(), "ray start failed");
        RayHead {
            ray,
            address: format!("127.0.0.1:{port}"),
        }
    }
}

impl Drop for RayHead {
    fn drop(&mut self) {
        let _ = Command::new(&self.ray)
            .args(["stop", "--force"])
            .stdout(Stdio::null())
            .stderr(Stdio::null())
            .status();
    }
}

/// results.csv without the machine's timing columns.
fn untimed(out: &Path) -> Vec<BTreeMap<String, String>> {
    rows(out)
        .into_iter()
        .map(|mut r| {
            r.retain(|k, _| !TIMING_COLUMNS.contains(&k.as_str()));
            r
        })
        .collect()
}

#[test]
fn the_ray_backend_gives_the_local_results() {
    let dir = tempfile::tempdir().expect("tempdir");
    let args = ["--planners", "survey,fbe", "--seeds", "1", "--budget", "10"];
    let local = dir.path().join("local");
    run_sweep(&local, &args);
    let head = RayHead::start();
    let ray = dir.path().join("ray");
    let mut ray_args = args.to_vec();
    ray_args.extend(["--backend", "ray", "--ray-address", &head.address]);
    run_sweep(&ray, &ray_args);
    drop(head);
    let (a, b) = (untimed(&local), untimed(&ray));
    assert_eq!(a.len(), 2);
    assert!(a.iter().all(|r| r["status"] == "complete"));
    assert_eq!(a, b);
}

#[test]
fn each_slurm_array_task_runs_exactly_its_episode() {
    let dir = tempfile::tempdir().expect("tempdir");
    let out = dir.path().join("sweep");
    let args = [
        "--planners",
        "survey,fbe",
        "--seeds",
        "1",
        "--budget",
        "5",
        "--backend",
        "slurm",
        "--keep-frames",
        "false",
    ];
    let written = run_sweep(&out, &args);
    assert!(String::from_utf8_lossy(&written.stdout).contains("episode.sbatch"));
    let script = out.join("slurm/episode.sbatch");
    let submit = std::fs::read_to_string(out.join("slurm/submit.sh")).expect("submit.sh");
    assert!(submit.contains("--array=0-1 episode.sbatch"), "{submit}");
    assert!(
        !out.join("room").exists(),
        "writing the script runs nothing"
    );

    // Without an array index the task says so.
    let bare = Command::new("bash")
        .arg(&script)
        .env_remove("SLURM_ARRAY_TASK_ID")
        .output()
        .expect("bash");
    assert!(!bare.status.success());
    assert!(String::from_utf8_lossy(&bare.stderr).contains("sbatch --array"));

    // The sweep's order is world, planner, seed: index 1 is fbe, index 0 the survey.
    let complete = |planner: &str| episode(&out, planner, 1).join("metrics.json").exists();
    for (index, planner) in [(1, "fbe"), (0, "survey")] {
        let task = Command::new("bash")
            .arg(&script)
            .env("SLURM_ARRAY_TASK_ID", index.to_string())
            .output()
            .expect("bash");
        assert!(
            task.status.success(),
            "{}",
            String::from_utf8_lossy(&task.stderr)
        );
        let metrics = json(&episode(&out, planner, 1).join("metrics.json"));
        assert_eq!(metrics["planner"], planner);
        // The sweep's --keep-frames false reached the task: its images went once complete.
        let folder = episode(&out, planner, 1);
        assert!(folder.join("groundtruth.txt").exists());
        assert!(!folder.join("rgb").exists() && !folder.join("transforms.json").exists());
        assert_eq!(
            metrics["simulated_seconds"].as_f64().map(f64::round),
            Some(5.0)
        );
    }
    assert!(complete("fbe") && complete("survey"));
    let collect = Command::new(env!("CARGO_BIN_EXE_splatloop"))
        .args(["sweep", "collect", "--out"])
        .arg(&out)
        .output()
        .expect("collect");
    assert!(collect.status.success());
    let table = rows(&out);
    assert_eq!(table.len(), 2);
    assert_eq!(
        table
            .iter()
            .map(|r| (r["index"].as_str(), r["planner"].as_str()))
            .collect::<Vec<_>>(),
        [("0", "survey"), ("1", "fbe")]
    );
}

#[test]
fn seeds_and_worlds_are_read_as_a_shell_user_means_them() {
    use splatloop::sweep::{parse_seeds, resolve_worlds};
    assert_eq!(parse_seeds("1..3,7").expect("seeds"), [1, 2, 3, 7]);
    assert_eq!(parse_seeds("5").expect("seed"), [5]);
    assert!(parse_seeds("3..1").is_err());
    assert!(parse_seeds("1,2,1").is_err());
    assert!(parse_seeds("one").is_err());
    let pattern = repo_path("worlds/suite/office_0*.xml");
    let worlds = resolve_worlds(&[pattern.display().to_string()]).expect("worlds");
    let names: Vec<String> = worlds
        .iter()
        .map(|w| w.file_name().expect("name").to_string_lossy().into_owned())
        .collect();
    assert_eq!(
        names,
        [
            "office_01.xml",
            "office_02.xml",
            "office_03.xml",
            "office_04.xml"
        ]
    );
    assert!(resolve_worlds(&["worlds/none_*.xml".into()]).is_err());
    assert!(resolve_worlds(&[repo_path("worlds/missing.xml").display().to_string()]).is_err());
}

/// A fair comparison's protocol: with a factor of 1 or more the survey runs on to the factor
/// times its route's time, the others get that time, and every planner of a world and seed
/// has the same simulated seconds and mapping steps; summary.md says so and compares the
/// planners at equal times.
#[test]
fn a_survey_factor_sweep_gives_every_planner_the_same_time_and_mapping_steps() {
    let dir = tempfile::tempdir().expect("tempdir");
    let out = dir.path().join("sweep");
    let args = [
        "--planners",
        "survey,fbe",
        "--seeds",
        "1",
        "--budget-survey-factor",
        "1.2",
        "--survey-budget",
        "200",
        "--jobs",
        "1",
    ];
    run_sweep(&out, &args);
    let table = rows(&out);
    assert_eq!(table.len(), 2);
    let find = |p: &str| table.iter().find(|r| r["planner"] == p).expect("row");
    let (survey, fbe) = (find("survey"), find("fbe"));
    let done_at = number(survey, "done_at");
    assert!(
        (number(survey, "simulated_seconds") - 1.2 * done_at).abs() < 0.01,
        "{survey:?}"
    );
    for column in ["simulated_seconds", "mapping_steps"] {
        assert!(
            (number(survey, column) - number(fbe, column)).abs() < 1e-6,
            "{column}: survey {} fbe {}",
            survey[column],
            fbe[column]
        );
    }
    assert!(
        fbe["ended"].starts_with("budget (planner done at t = "),
        "{fbe:?}"
    );
    let summary = std::fs::read_to_string(out.join("summary.md")).expect("summary.md");
    assert!(
        summary.contains("Protocol: every episode runs to its budget"),
        "{summary}"
    );
    assert!(
        summary.contains("Mapping steps (mean [min, max]): survey "),
        "{summary}"
    );
    assert!(summary.contains("## At equal times"), "{summary}");
}
