//! `roadvo`: the command line. Each subcommand is one args struct in [`cli`] with its own `run`:
//! it parses, calls into the library, shows progress and prints what it did.

mod cli;

use clap::Parser;

fn main() -> anyhow::Result<()> {
    roadvo_sim::interrupt::file_size_limit_as_error();
    roadvo_sim::interrupt::broken_pipe_ends_quietly();
    cli::Cli::parse().command.run()
}
