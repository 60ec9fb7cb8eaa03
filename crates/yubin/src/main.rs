//! `yubin`: the command-line renderer (see the library's docs).

use std::process::ExitCode;
use yubin::{Cli, Parser};

fn main() -> ExitCode {
    yubin::run(Cli::parse())
}
