//! `sweep --backend slurm`: an sbatch array script whose task N runs episode N of the sweep
//! (`splatloop sweep episode --out DIR --index N`), and a submit script that queues the
//! surveys, then the planners after them, then the `collect` step after those.

use super::spec::Sweep;
use crate::error::{Result, SimError};
use std::path::{Path, PathBuf};

/// The files written.
#[derive(Debug, Clone)]
pub struct SlurmFiles {
    /// The array job script (one episode per array index).
    pub script: PathBuf,
    /// The script that submits the arrays and the collect step with their dependencies.
    pub submit: PathBuf,
}

/// The per-task command of the array script: what `episode.sbatch` runs for one index.
pub fn task_command(binary: &Path, out: &Path, index: &str) -> String {
    format!(
        "{} sweep episode --out {} --index {index}",
        quote(&binary.display().to_string()),
        quote(&out.display().to_string())
    )
}

/// Writes OUT/slurm/episode.sbatch and OUT/slurm/submit.sh for `binary`, `cpus` per task.
pub fn write_slurm(sweep: &Sweep, binary: &Path, cpus: usize) -> Result<SlurmFiles> {
    let dir = sweep.out.join("slurm");
    std::fs::create_dir_all(&dir).map_err(|e| SimError::io("cannot create", &dir, e))?;
    let cwd = std::env::current_dir().map_err(|e| SimError::io("cannot read", ".", e))?;
    let script = dir.join("episode.sbatch");
    let logs = dir.join("%A_%a.out");
    let text = format!(
        "#!/bin/bash\n\
         # One episode of the splatloop sweep in {out}, by its array index (submit.sh queues\n\
         # them all). Runs nothing for an episode that is already complete.\n\
         #SBATCH --job-name=splatloop-sweep\n\
         #SBATCH --output={logs}\n\
         #SBATCH --ntasks=1\n\
         #SBATCH --cpus-per-task={cpus}\n\
         set -euo pipefail\n\
         cd {cwd}\n\
         exec {command}\n",
        out = sweep.out.display(),
        logs = logs.display(),
        cwd = quote(&cwd.display().to_string()),
        command = task_command(
            binary,
            &sweep.out,
            "\"${SLURM_ARRAY_TASK_ID:?run by sbatch --array (see submit.sh)}\""
        ),
    );
    write_executable(&script, &text)?;

    let mut submit = String::from(
        "#!/bin/bash\n\
         # Queues the sweep on Slurm: each batch an array job after the one before it (the\n\
         # surveys first where they set the planners' budgets), then the collect step.\n\
         set -euo pipefail\n\
         cd \"$(dirname \"$0\")\"\n\
         after=\"\"\n",
    );
    for batch in sweep.batches() {
        let (first, last) = (batch[0], batch[batch.len() - 1]);
        submit.push_str(&format!(
            "job=$(sbatch --parsable ${{after:+--dependency=afterany:$after}} --array={first}-{last} episode.sbatch)\n\
             echo \"episodes {first}-{last}: job $job\"\n\
             after=$job\n"
        ));
    }
    let collect = format!(
        "{} sweep collect --out {}",
        quote(&binary.display().to_string()),
        quote(&sweep.out.display().to_string())
    );
    submit.push_str(&format!(
        "sbatch --parsable --dependency=afterany:$after --job-name=splatloop-collect --output={} --wrap {}\n",
        quote(&dir.join("collect.out").display().to_string()),
        quote(&format!("cd {} && {collect}", quote(&cwd.display().to_string())))
    ));
    let submit_path = dir.join("submit.sh");
    write_executable(&submit_path, &submit)?;
    Ok(SlurmFiles {
        script,
        submit: submit_path,
    })
}

fn write_executable(path: &Path, text: &str) -> Result<()> {
    use std::os::unix::fs::PermissionsExt;
    std::fs::write(path, text).map_err(|e| SimError::io("cannot write", path, e))?;
    std::fs::set_permissions(path, std::fs::Permissions::from_mode(0o755))
        .map_err(|e| SimError::io("cannot make executable", path, e))
}

/// A word for bash: single-quoted, with single quotes inside it escaped.
fn quote(word: &str) -> String {
    format!("'{}'", word.replace('\'', r"'\''"))
}
