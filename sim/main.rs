//! The `splatloop` command line: parses, then dispatches to the library's commands.

use clap::{CommandFactory, FromArgMatches};
use splatloop::commands::{run, Cli};

fn main() -> std::process::ExitCode {
    // --version names the MuJoCo this binary runs (and the one it was built against); the
    // string lives as long as the process, as clap wants.
    let version = format!(
        "{} (MuJoCo {}, built against {})",
        env!("CARGO_PKG_VERSION"),
        splatloop::mujoco::version(),
        splatloop::mujoco::HEADER_VERSION
    );
    let cli = match Cli::command()
        .version(&*version.leak())
        .try_get_matches()
        .and_then(|m| Cli::from_arg_matches(&m))
    {
        Ok(cli) => cli,
        Err(e) => e.exit(),
    };
    // A filter that does not parse is an error, not a silent `info`.
    let filter = match cli.log.parse::<tracing_subscriber::filter::Targets>() {
        Ok(_) => tracing_subscriber::EnvFilter::try_new(&cli.log).ok(),
        Err(_) => None,
    };
    let Some(filter) = filter else {
        eprintln!(
            "error: invalid --log {:?}: give error, warn, info, debug, trace, or a directive such as splatloop=debug,wgpu=warn",
            cli.log
        );
        return std::process::ExitCode::from(2);
    };
    tracing_subscriber::fmt()
        .with_env_filter(filter)
        .with_writer(std::io::stderr)
        .init();
    match run(cli.command) {
        Ok(Some(code)) => std::process::ExitCode::from(code),
        Ok(None) => std::process::ExitCode::SUCCESS,
        Err(e) => {
            eprintln!("error: {e:#}");
            std::process::ExitCode::FAILURE
        }
    }
}
