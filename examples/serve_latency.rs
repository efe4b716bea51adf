//! Save-to-pixels latency of `texgraph serve`, as an author sees it: a page client (WebSocket)
//! watches a copy of the seed 003 marble while the file is saved again and again with a new
//! `period`; for each save, the time from the write to the first (draft) preview and to the
//! full-resolution preview arriving at the client.
//!
//! ```text
//! cargo run --release --example serve_latency [-- SAVES]
//! ```

use futures_util::StreamExt;
use serde_json::Value;
use std::time::{Duration, Instant};

fn main() {
    let saves: usize = std::env::args()
        .nth(1)
        .and_then(|a| a.parse().ok())
        .unwrap_or(20);
    let dir = tempfile::tempdir().expect("a temporary folder");
    let path = dir.path().join("marble.ron");
    let marble = concat!(env!("CARGO_MANIFEST_DIR"), "/graphs/seed003_marble.ron");
    let original = std::fs::read_to_string(marble).expect("the seed 003 marble");
    std::fs::write(&path, &original).expect("a copy");
    let server = texgraph::serve::start(texgraph::serve::ServeOptions {
        input: path.clone(),
        host: "127.0.0.1".parse().unwrap(),
        port: 0,
        sizes: texgraph::serve::Sizes::default(),
    })
    .expect("the server starts");
    let runtime = tokio::runtime::Builder::new_current_thread()
        .enable_all()
        .build()
        .unwrap();
    let (drafts, fulls) = runtime.block_on(async {
        let url = format!("ws://{}/ws", server.addr());
        let (mut socket, _) = tokio_tungstenite::connect_async(url).await.unwrap();
        // Wait for the first full preview.
        next_preview(&mut socket, "full", Duration::from_secs(30)).await;
        let mut drafts = Vec::new();
        let mut fulls = Vec::new();
        for k in 0..saves {
            let period = format!("\"period\": {:?},", 1.0 + 0.05 * k as f64);
            let text = original.replace("\"period\": 1.3,", &period);
            let saved = Instant::now();
            std::fs::write(&path, text).unwrap();
            next_preview(&mut socket, "draft", Duration::from_secs(30)).await;
            drafts.push(saved.elapsed());
            next_preview(&mut socket, "full", Duration::from_secs(30)).await;
            fulls.push(saved.elapsed());
            // Let the file system settle so each save is its own edit.
            tokio::time::sleep(Duration::from_millis(200)).await;
        }
        (drafts, fulls)
    });
    let cpu = std::fs::read_to_string("/proc/cpuinfo")
        .ok()
        .and_then(|c| {
            c.lines()
                .find(|l| l.starts_with("model name"))
                .map(|l| l.split(':').nth(1).unwrap_or("").trim().to_string())
        })
        .unwrap_or_else(|| "unknown CPU".into());
    println!(
        "seed 003 marble, {saves} saves, {} threads, {cpu}",
        std::thread::available_parallelism().map_or(1, |n| n.get())
    );
    report("save -> draft preview (128x128, 1 spp)", drafts);
    report("save -> full preview (512x512, 4 spp)", fulls);
}

/// Reads messages until a preview of `stage` arrives.
async fn next_preview<S>(socket: &mut S, stage: &str, limit: Duration)
where
    S: futures_util::Stream<
            Item = Result<
                tokio_tungstenite::tungstenite::Message,
                tokio_tungstenite::tungstenite::Error,
            >,
        > + Unpin,
{
    let deadline = Instant::now() + limit;
    loop {
        let left = deadline.saturating_duration_since(Instant::now());
        let message = tokio::time::timeout(left, socket.next())
            .await
            .expect("a preview in time")
            .expect("the connection stays open")
            .expect("a message");
        if let tokio_tungstenite::tungstenite::Message::Text(text) = message {
            let value: Value = serde_json::from_str(text.as_str()).unwrap();
            if value["type"] == "preview" && value["stage"] == stage {
                return;
            }
        }
    }
}

fn report(what: &str, mut times: Vec<Duration>) {
    times.sort();
    let ms = |d: Duration| d.as_secs_f64() * 1e3;
    println!(
        "{what}: median {:.1} ms, min {:.1} ms, max {:.1} ms",
        ms(times[times.len() / 2]),
        ms(times[0]),
        ms(times[times.len() - 1])
    );
}
