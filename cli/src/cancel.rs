//! Ctrl-C: the first stops the launches running now (they return a "cancelled" error,
//! which the command reports) and quits two seconds later if the command has not ended by
//! itself (it may be reading files or building); a second quits at once. Exit status 130,
//! as a shell reports a SIGINT.

/// Installs the handler; without it (or where signals cannot be caught) Ctrl-C ends the
/// process as usual.
pub fn install() {
    #[cfg(unix)]
    {
        use signal_hook::consts::SIGINT;
        let Ok(mut signals) = signal_hook::iterator::Signals::new([SIGINT]) else {
            return;
        };
        // If the thread cannot start, `signals` drops with the closure and unregisters.
        let _ = std::thread::Builder::new()
            .name("optik ctrl-c".into())
            .spawn(move || {
                let mut first = true;
                for _ in signals.forever() {
                    if !first {
                        std::process::exit(130);
                    }
                    first = false;
                    eprintln!(
                        "optik: interrupted: stopping the running launch (Ctrl-C again quits at once)"
                    );
                    optik::interrupt_launches();
                    std::thread::spawn(|| {
                        std::thread::sleep(std::time::Duration::from_secs(2));
                        std::process::exit(130);
                    });
                }
            });
    }
}
