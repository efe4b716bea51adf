//! `texgraph serve`.

use super::*;
use clap::Args;
use std::path::PathBuf;

#[derive(Args)]
pub struct ServeArgs {
    /// A graph file, a scene file, or a folder of graph files.
    #[arg(value_name = "FILE")]
    file: PathBuf,
    /// The port to listen on (0: any free port).
    #[arg(long, default_value_t = 7878)]
    port: u16,
    /// The address to listen on. The page has no authentication: anything other than a
    /// loopback address lets other machines read the served files' values and write params.
    #[arg(long, default_value = "127.0.0.1", value_name = "ADDR")]
    host: std::net::IpAddr,
    /// Open the page in the default browser.
    #[arg(long)]
    open: bool,
}

/// Serves the page until interrupted.
pub fn serve(args: ServeArgs) -> Result<(), Failure> {
    let server = crate::serve::start(crate::serve::ServeOptions {
        input: args.file,
        host: args.host,
        port: args.port,
    })
    .map_err(|e| {
        eprintln!("error: {e}");
        Failure::Usage
    })?;
    let url = server.url();
    println!("texgraph serve: {url} (Ctrl-C stops)");
    if !args.host.is_loopback() {
        eprintln!("warning: listening on {}: anyone who can reach it can read and edit the served graphs' params", args.host);
    }
    if args.open {
        open_browser(&url);
    }
    server.wait();
    Ok(())
}

/// Opens `url` with the desktop's opener (best effort: a failure is a warning).
fn open_browser(url: &str) {
    let opener = if cfg!(target_os = "macos") {
        "open"
    } else if cfg!(target_os = "windows") {
        "explorer"
    } else {
        "xdg-open"
    };
    if let Err(e) = std::process::Command::new(opener)
        .arg(url)
        .stdin(std::process::Stdio::null())
        .stdout(std::process::Stdio::null())
        .stderr(std::process::Stdio::null())
        .spawn()
    {
        eprintln!("warning: could not open a browser ({opener}: {e}); open {url} yourself");
    }
}
