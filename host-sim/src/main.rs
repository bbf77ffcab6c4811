use clap::Parser;

fn main() -> std::process::ExitCode {
    vorl_host_sim::cli::run(vorl_host_sim::cli::Cli::parse())
}
