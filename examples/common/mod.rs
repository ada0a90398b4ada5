//! What the examples share: their log subscriber. The library never installs one; an
//! application chooses its own, as these examples do.

/// Installs the stderr subscriber of an example: `RUST_LOG` if set, else `default_level`;
/// human-readable (colour codes only on a terminal, so a redirected log stays plain text),
/// or JSON lines with the current span when `json`.
pub fn init_logs(default_level: &str, json: bool) {
    let filter = tracing_subscriber::EnvFilter::try_from_default_env()
        .unwrap_or_else(|_| tracing_subscriber::EnvFilter::new(default_level));
    let builder = tracing_subscriber::fmt()
        .with_writer(std::io::stderr)
        .with_ansi(std::io::IsTerminal::is_terminal(&std::io::stderr()))
        .with_env_filter(filter);
    if json {
        builder.json().with_current_span(true).init();
    } else {
        builder.init();
    }
}
