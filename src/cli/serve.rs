//! `texgraph serve`.

use super::*;
use clap::Args;
#[cfg(feature = "serve")]
use std::path::PathBuf;

#[cfg(feature = "serve")]
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
    /// The preview's side in pixels when the page opens (1 to 2048; the page can change it).
    #[arg(long, default_value_t = crate::serve::Sizes::default().preview, value_name = "PIXELS")]
    preview_size: u32,
    /// The slice's side in pixels (1 to 2048).
    #[arg(long, default_value_t = crate::serve::Sizes::default().slice, value_name = "PIXELS")]
    slice_size: u32,
    /// The node thumbnails' side in pixels (1 to 512).
    #[arg(long, default_value_t = crate::serve::Sizes::default().thumb, value_name = "PIXELS")]
    thumb_size: u32,
}

/// Without the `serve` feature: whatever follows `serve` is taken, and refused.
#[cfg(not(feature = "serve"))]
#[derive(Args)]
pub struct ServeArgs {
    #[arg(
        trailing_var_arg = true,
        allow_hyphen_values = true,
        value_name = "ARGS"
    )]
    _args: Vec<String>,
}

/// Without the `serve` feature: refused (exit code 2).
#[cfg(not(feature = "serve"))]
pub fn serve(_: ServeArgs) -> Result<(), Failure> {
    eprintln!(
        "error: {}",
        crate::diagnostic::without_feature("texgraph serve", "serve")
    );
    Err(Failure::Usage)
}

/// Serves the page until interrupted.
#[cfg(feature = "serve")]
pub fn serve(args: ServeArgs) -> Result<(), Failure> {
    let server = crate::serve::start(crate::serve::ServeOptions {
        input: args.file,
        host: args.host,
        port: args.port,
        sizes: crate::serve::Sizes {
            preview: args.preview_size,
            slice: args.slice_size,
            thumb: args.thumb_size,
        },
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
#[cfg(feature = "serve")]
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
