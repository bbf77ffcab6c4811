use clap::Parser;

fn main() -> std::process::ExitCode {
    // `vorl detect … | head` closes the pipe early; `println!` then panics. Leave quietly instead,
    // with the shell's usual status for SIGPIPE.
    let default_hook = std::panic::take_hook();
    std::panic::set_hook(Box::new(move |info| {
        let text = info
            .payload()
            .downcast_ref::<String>()
            .map(String::as_str)
            .or_else(|| info.payload().downcast_ref::<&str>().copied())
            .unwrap_or("");
        if text.contains("Broken pipe") {
            std::process::exit(141);
        }
        default_hook(info);
    }));
    vorl_host_sim::cli::run(vorl_host_sim::cli::Cli::parse())
}
