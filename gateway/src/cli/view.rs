//! `petrel view FILE.mcap [PROJECT]`: the monitor's page over a recorded
//! flight, for the debrief. The player replays the recording's own inputs
//! (`replay`'s path: `replay::from_mcap::open` and `input`), once, while
//! the monitor indexes what the page shows (`monitor::history`); the page
//! then scrubs, steps and plays through the flight from that index.

use std::net::SocketAddr;
use std::path::PathBuf;
use std::sync::Arc;
use std::time::Instant;

use super::replay::from_mcap;
use super::{Outcome, VerbResult};
use petrel_core::supervisor::Supervisor;
use petrel_record::check::compare;
use petrel_web::monitor::history::{Builder, History};
use petrel_web::monitor::{page, Server, Source};

#[derive(clap::Args)]
pub struct Args {
    /// The Petrel recording (.mcap).
    pub file: PathBuf,
    /// The project folder it flew [default: the built-in example
    /// `--example` names].
    pub project: Option<PathBuf>,
    /// Without PROJECT: the built-in example the recording flew (`petrel
    /// demo --example`).
    #[arg(
        long,
        value_enum,
        default_value = "uav-flight-test",
        conflicts_with = "project"
    )]
    pub example: super::examples::Example,
    /// Elaboration profile [default: the one recorded with the flight].
    #[arg(long)]
    pub profile: Option<String>,
    /// Serve the page on ADDR:PORT, or 127.0.0.1:PORT given a port
    /// [default: 127.0.0.1:8090, else a free port on 127.0.0.1].
    #[arg(long, value_name = "ADDR:PORT")]
    pub http: Option<String>,
    /// Do not serve: index the recording, time N instants picked across it
    /// (the page's scrubbing, without the browser), print the figures and
    /// exit (`cargo bench --bench view`).
    #[arg(long, value_name = "N", hide = true)]
    pub measure: Option<usize>,
}

pub fn run(args: Args) -> VerbResult {
    let address: SocketAddr = match &args.http {
        Some(a) => petrel_web::monitor::parse_address(a).map_err(|e| miette::miette!("{e}"))?,
        None => {
            let port = if std::net::TcpListener::bind("127.0.0.1:8090").is_ok() {
                8090
            } else {
                0
            };
            SocketAddr::from(([127, 0, 0, 1], port))
        }
    };
    let (dir, unpacked) = match &args.project {
        Some(d) => (d.clone(), false),
        None => (super::examples::unpack(args.example)?, true),
    };
    let opened = Instant::now();
    let history = index(&args, &dir);
    if unpacked {
        let _ = std::fs::remove_dir_all(&dir);
    }
    let Some(history) = history? else {
        return Ok(Outcome::BadInput);
    };
    let indexed = opened.elapsed();
    if let Some(n) = args.measure {
        measure(&history, n, indexed);
        return Ok(Outcome::Success);
    }
    let server = Server::start(address, Source::Recording(Arc::new(history)))
        .map_err(|e| miette::miette!("cannot serve the page on {address}: {e}"))?;
    say!(
        "view: http://{}/ (indexed in {:.2} s; Ctrl-C stops)",
        server.address,
        indexed.as_secs_f64()
    );
    server.wait();
    Ok(Outcome::Success)
}

/// Replays the recording once and indexes it; `None` when its profile
/// does not load (already reported).
fn index(args: &Args, dir: &std::path::Path) -> Result<Option<History>, miette::Report> {
    let name = args.file.display().to_string();
    let Some(mut opened) = from_mcap::open(&args.file, dir, args.profile.as_deref(), true)? else {
        return Ok(None);
    };
    let (origin, mut project) = (opened.origin, opened.project.clone());
    let lanes = std::mem::take(&mut opened.lanes);
    let rec = &opened.rec;
    let (mut sup, start) = Supervisor::start_lanes(project.clone(), lanes, origin);
    let mut builder = Builder::new(project.clone(), &start, sup.player(), origin);
    // The recorded digests tell whether this is the project that flew.
    let mut difference = compare(&project, &start, &sup.player().digest(), rec.steps.get(&0));
    for (seq, time, recorded) in rec.inputs.iter().skip(1) {
        if *seq != sup.seq() + 1 {
            say!(
                "warning: the recording jumps from step {} to step {seq} (the recorder dropped steps): the view stops there",
                sup.seq()
            );
            break;
        }
        let input = from_mcap::input(&opened, *seq, recorded)
            .map_err(|e| miette::miette!("{name}: {e}"))?;
        let step = sup.step(*time, input.clone());
        if !std::sync::Arc::ptr_eq(sup.player().project(), &project) {
            project = sup.player().project().clone();
        }
        builder.step(&input, &step, sup.player());
        if difference.is_none() {
            difference = compare(&project, &step, &sup.player().digest(), rec.steps.get(seq));
        }
    }
    if let Some(d) = difference {
        say!(
            "warning: replaying with {} differs from the recording at step {} ({}): is it the project that flew?",
            dir.display(),
            d.seq,
            d.what
        );
    }
    Ok(Some(
        builder.finish(|p| page::page(p, Some(dir), "recording")),
    ))
}

/// Times `n` instants spread over the recording, as the page asks for them.
fn measure(history: &History, n: usize, indexed: std::time::Duration) {
    let n = n.max(1);
    let span = history.end.saturating_sub(history.start);
    let mut times: Vec<f64> = (0..n)
        .map(|i| {
            // Spread, and visited out of order as a scrubbing hand does.
            let k = (i * 7919) % n;
            let at = history.start + span * k as u64 / n as u64;
            let t = Instant::now();
            let text = history.frame_at(at).to_string();
            std::hint::black_box(text);
            t.elapsed().as_secs_f64() * 1e3
        })
        .collect();
    times.sort_by(f64::total_cmp);
    let pct = |p: f64| times[((times.len() - 1) as f64 * p) as usize];
    show!(
        "{}",
        serde_json::json!({
            "indexed_s": indexed.as_secs_f64(),
            "flight_s": nets::time::seconds(span),
            "instants": n,
            "frame_ms_median": pct(0.5),
            "frame_ms_p99": pct(0.99),
            "frame_ms_max": pct(1.0),
        })
    );
}
