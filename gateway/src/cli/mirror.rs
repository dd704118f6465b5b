//! `petrel mirror PROJECT`: the ground mirror (docs/mirror.md). On the
//! telemetry the ground station receives, it replays the vehicle's player
//! from the downlink `petrel run --downlink` publishes, checks its digest
//! against the vehicle's at every record and heartbeat, asks for what the
//! radio lost, and prints the vehicle's steps — the commands and calls the
//! vehicle made, shown, never carried out — with `mirror_resynced` and
//! `mirror_diverged` as they happen.
//!
//! It never commands the vehicle nor calls a program: the only thing it
//! holds to send with is an `UplinkWriter`, which sends resync requests.

use std::io::Write;
use std::path::PathBuf;
use std::sync::Arc;
use std::time::{Duration, Instant};

use nets::{Micros, Project};
use serde_json::json;
use tokio::sync::mpsc;

use super::timeline::Timeline;
use super::VerbResult;
use crate::clock::Clock;
use crate::link::uplink::UplinkWriter;
use crate::link::Link;
use petrel_core::mirror::call::call_json;
use petrel_core::mirror::check::Disagreement;
use petrel_core::mirror::ground::Ground;
use petrel_core::mirror::record::Input;
use petrel_core::mirror::replica::{Replica, Report};
use petrel_core::mirror::station::{Config as StationConfig, Output, Station, SILENCE_WARNING};
use petrel_record::layout;
use petrel_record::recorder::{Options as RecordOptions, Recorder};

mod push;

#[derive(clap::Args)]
pub struct Args {
    /// The project folder: the same project the vehicle runs.
    pub project: PathBuf,
    /// The ground's MAVLink link, as for `run` (udpin:, udpout:, tcpout:,
    /// tcpin:, serial:PORT:BAUD) [default: `[gateway] mirror_mavlink`].
    #[arg(long, value_name = "ADDRESS")]
    pub mavlink: Option<String>,
    /// Elaboration profile, as for `run`.
    #[arg(long)]
    pub profile: Option<String>,
    /// The mirror's own MAVLink system id (never the ground station's 255)
    /// [default: `[gateway] mirror_system`, else 245].
    #[arg(long, value_name = "ID")]
    pub system: Option<u8>,
    /// The gateway's clock factor, as for `run` (simulated vehicles only).
    #[arg(long, value_name = "FACTOR", default_value_t = 1.0)]
    pub time_scale: f64,
    /// Stop after this many seconds of wall-clock time.
    #[arg(long, value_name = "SECONDS")]
    pub duration: Option<f64>,
    /// Print the timeline as JSON lines.
    #[arg(long)]
    pub json: bool,
    /// The operator key (the same file as `petrel run --operator-key`):
    /// the nets' questions (`ask`) are shown with a countdown and answered
    /// on stdin as `ID CHOICE` (or `CHOICE` when one question is pending),
    /// sent up signed with it (docs/mirror.md, "Operator dialog"); `push
    /// DIR` on stdin sends a new version up (as --push).
    #[arg(long, value_name = "FILE")]
    pub operator_key: Option<PathBuf>,
    /// The vehicle's MAVLink signing key (the file `petrel run
    /// --signing-key` reads): downlink records are taken only in frames
    /// signed with it; unsigned, altered, replayed or stale ones are
    /// refused and counted (docs/mirror.md, "A signed downlink").
    #[arg(long, value_name = "FILE")]
    pub signing_key: Option<PathBuf>,
    /// Record the mirror to this MCAP file: `run`'s layout, the replica's
    /// calls as its steps, plus the mirror's channels (docs/mirror.md,
    /// "The mirror's recording"); `petrel replay --check-against` replays
    /// it [default: recordings/mirror-<UTC date and time>.mcap].
    // The text is `--help`'s, where `<…>` is no HTML tag.
    #[allow(rustdoc::invalid_html_tags)]
    #[arg(long, value_name = "FILE", conflicts_with = "no_record")]
    pub record: Option<PathBuf>,
    /// Do not record.
    #[arg(long)]
    pub no_record: bool,
    /// Serve the web monitor (docs/monitor.md, "On the mirror") on
    /// ADDRESS:PORT, or on 127.0.0.1:PORT given a port alone: the replica's
    /// nets, its agreement with the vehicle, the disagreements, and the
    /// questions with answer buttons (with --operator-key; read-only
    /// without).
    #[arg(long, value_name = "ADDRESS:PORT")]
    pub http: Option<String>,
    /// Send a new version of the project up to the vehicle: the project
    /// folder DIR, checked here first, packed, sent in pieces signed with
    /// --operator-key (required) at the rate of --push-rate, the missing
    /// pieces again; the vehicle proves it from the state it is in and
    /// says its verdict (docs/mirror.md, "A version sent up"). The replica
    /// follows the vehicle onto it.
    #[arg(long, value_name = "DIR", requires = "operator_key")]
    pub push: Option<PathBuf>,
    /// The uplink bytes per second the version may take (a radio's share).
    #[arg(long, value_name = "BYTES", default_value_t = 1000)]
    pub push_rate: u64,
}

/// How often the replica and the ground's elaboration are ticked.
const TICK: Micros = 100_000;

pub fn run(args: Args) -> VerbResult {
    let gateway = petrel_core::project::gateway_table(&args.project)?;
    let get = |key: &str| gateway.get(key).and_then(|v| v.as_str()).map(str::to_owned);
    let layers = petrel_core::profile::Layers::pick(
        args.profile.as_deref(),
        Some((&args.project, get("profile").as_deref())),
        "ardupilot",
    )?;
    let Some(profile) = crate::cli::loaded(&layers) else {
        return Ok(super::Outcome::BadInput);
    };
    let project =
        petrel_core::project::load_with(&args.project, &petrel_core::project::catalog(&profile))?;
    let Some(address) = args.mavlink.clone().or_else(|| get("mirror_mavlink")) else {
        return Err(miette::miette!(
            "no MAVLink link: give --mavlink ADDRESS (the ground's telemetry, e.g. udpin:0.0.0.0:14551 from mavlink-router or MAVProxy --out)"
        ));
    };
    let system = match args.system {
        Some(s) => s,
        None => match gateway.get("mirror_system").and_then(|v| v.as_integer()) {
            Some(v) => u8::try_from(v)
                .map_err(|_| miette::miette!("[gateway] mirror_system {v} is not a system id"))?,
            None => petrel_core::mirror::MIRROR_SYSTEM,
        },
    };
    if system == 255 || system == 0 {
        return Err(miette::miette!(
            "the mirror's system id cannot be {system}: 255 is the ground station's (SYSID_MYGCS), 0 is broadcast"
        ));
    }
    super::run::check_timing(args.duration, args.time_scale)?;
    let operator = match &args.operator_key {
        None => None,
        Some(path) => {
            Some(petrel_core::signing::Key::load(path).map_err(|e| miette::miette!("{e}"))?)
        }
    };
    let signing = match &args.signing_key {
        None => None,
        Some(path) => {
            Some(petrel_core::signing::Key::load(path).map_err(|e| miette::miette!("{e}"))?)
        }
    };
    let http = match &args.http {
        Some(a) => Some(petrel_web::monitor::parse_address(a).map_err(|e| miette::miette!("{e}"))?),
        None => None,
    };
    let record = if args.no_record {
        None
    } else {
        Some(
            args.record
                .clone()
                .unwrap_or_else(|| super::run::dated_recording("mirror")),
        )
    };
    // The ground elaborates each vehicle in its lane, as `petrel run` does
    // on board (one lane, unqualified, without a team).
    let lanes = petrel_core::team::lanes(
        &project,
        &args.project,
        &profile,
        petrel_core::team::family(&layers.layers),
        &elaboration::Config::default(),
    )?;
    let catalog = petrel_core::project::catalog(&profile);
    let push = match &args.push {
        None => None,
        Some(dir) => {
            let push = push::prepare(dir, &catalog, &layers.layers)?;
            say!("{}", push.summary(args.push_rate));
            Some(push)
        }
    };
    let runtime = tokio::runtime::Builder::new_current_thread()
        .enable_all()
        .build()
        .map_err(|e| miette::miette!("cannot start the runtime: {e}"))?;
    let result = runtime.block_on(mirror(Setup {
        project,
        address,
        system,
        lanes,
        json: args.json,
        time_scale: args.time_scale,
        duration: args.duration.map(Duration::from_secs_f64),
        operator,
        signing,
        record,
        layers,
        http,
        dir: args.project.clone(),
        catalog,
        push,
        push_rate: args.push_rate,
    }));
    // The operator's stdin is read on a blocking thread that no abort
    // stops: waiting for it would hold the mirror until the next line.
    runtime.shutdown_background();
    result
}

struct Setup {
    project: Arc<Project>,
    address: String,
    system: u8,
    /// The ground's elaboration: one lane per vehicle of the team.
    lanes: Vec<petrel_core::supervisor::Lane>,
    json: bool,
    time_scale: f64,
    duration: Option<Duration>,
    /// The operator key: the dialog is on.
    operator: Option<petrel_core::signing::Key>,
    /// The vehicle's signing key: the downlink must be signed with it.
    signing: Option<petrel_core::signing::Key>,
    /// Where to record.
    record: Option<PathBuf>,
    /// The profile's layers, recorded with the start.
    layers: petrel_core::profile::Layers,
    /// Serve the web monitor here.
    http: Option<std::net::SocketAddr>,
    /// The project's folder (the page shows the nets' files).
    dir: PathBuf,
    /// The events the profile produces: a version read again (SIGHUP)
    /// loads with them.
    catalog: nets::load::Catalog,
    /// A version to send up, and at what byte rate.
    push: Option<push::Push>,
    push_rate: u64,
}

/// The project folder read again (SIGHUP): a version the vehicle may take
/// over, for the replica to follow it.
fn read_version(
    dir: &std::path::Path,
    catalog: &nets::load::Catalog,
) -> Result<petrel_core::version::Version, String> {
    let (project, files) = petrel_core::project::load_read(dir, catalog)
        .map_err(|e| petrel_core::project::for_people(&e))?;
    Ok(petrel_core::version::Version {
        number: 0,
        project,
        files,
    })
}

async fn mirror(setup: Setup) -> VerbResult {
    let origin = Instant::now();
    let clock = Clock::new(origin, setup.time_scale);
    // Signals are watched from here on: a stop while a `tcpin:` link waits
    // for its client ends cleanly too, as `run`'s (docs/run.md).
    let mut signals = super::run::Signals::new()?;
    let mut hangups = super::run::Hangup::new()?;
    let (versions_tx, mut versions) = mpsc::unbounded_channel();
    let opened = signals
        .or_stop(
            Link::open(&setup.address, clock.clone()),
            setup.duration.map(|d| origin + d),
        )
        .await;
    let (mut reader, writer) = match opened {
        Ok(opened) => opened.map_err(|e| miette::miette!("{e}"))?,
        Err(stopped) => {
            say!(
                "{}",
                stopped.before_the_link("mirror", &setup.address, origin.elapsed())
            );
            return Ok(super::Outcome::Success);
        }
    };
    // With the vehicle's key, the mirror's requests go up signed with it
    // too: a vehicle that requires signatures (`run --require-signed`)
    // takes them.
    if let Some(key) = &setup.signing {
        writer.sign(petrel_core::signing::Signer::new(key.clone(), 0, None));
    }
    let uplink = UplinkWriter::new(writer, setup.system);
    // The recording is created once the link is open, as `run`'s.
    let recorder = match &setup.record {
        None => None,
        Some(path) => {
            let unix_ns = std::time::SystemTime::now()
                .duration_since(std::time::UNIX_EPOCH)
                .map_or(0, |d| d.as_nanos() as u64);
            let options = RecordOptions {
                clock_offset_ns: unix_ns,
                profile: setup.layers.name.clone(),
                profile_layers: setup.layers.layers.clone(),
                config: elaboration::Config::default(),
                writer_started: crate::scheduling::recorder_thread,
                ..RecordOptions::default()
            };
            let rec = Recorder::create(path, setup.project.clone(), options)
                .map_err(|e| miette::miette!("cannot record to {}: {e}", path.display()))?;
            // Step 0: a player's start at vehicle time 0, as `petrel
            // replay` starts one; the replica's own start is a call.
            let mut player = nets::Player::start(setup.project.clone(), 0);
            let start = petrel_core::supervisor::Step {
                seq: 0,
                time: 0,
                events: Vec::new(),
                effects: player.effects().collect(),
            };
            rec.start(&start, &player);
            say!("recording to {}", path.display());
            Some(rec)
        }
    };
    // The page: fed at the end of each turn of the loop, answers from it
    // taken as those typed on stdin (`answer`).
    let (mut page, mut page_answers) = match setup.http {
        None => (None, None),
        Some(address) => {
            let answering = match &setup.operator {
                Some(_) => Ok(()),
                None => Err(
                    "no operator key in this mirror (petrel mirror --operator-key FILE)".to_owned(),
                ),
            };
            let (page, answers) = petrel_web::monitor::mirror_page::Page::start(
                address,
                setup.project.clone(),
                &setup.dir,
                answering,
            )
            .map_err(|e| miette::miette!("cannot serve the monitor on {address}: {e}"))?;
            say!("monitor: http://{}/", page.server.address);
            (Some(page), answers)
        }
    };
    let mut calls = 0u64;
    // The version the replica's reports are printed with.
    let mut printed = setup.project.clone();
    let mut station = Station::new(StationConfig {
        project: setup.project.clone(),
        system: setup.system,
        identity: uplink.identity(),
        lanes: setup.lanes,
        signing: setup.signing.clone(),
        dialog: setup.operator.is_some(),
        record: recorder.is_some(),
    });
    if let Some(p) = setup.push {
        push::start(&mut station, clock.now(), p, setup.push_rate);
    }
    // Versions to push typed on stdin (`push DIR`), prepared off the loop.
    let (pushes_tx, mut pushes) = mpsc::unbounded_channel();
    let mut pushed_tenth = 0;
    let mut out = Timeline {
        out: std::io::BufWriter::new(std::io::stdout()),
        json: setup.json,
        origin: 0,
    };
    let (frames_tx, mut frames) = mpsc::channel(1024);
    let reader_task = tokio::spawn(async move {
        loop {
            match reader.recv().await {
                Ok(rx) => {
                    if frames_tx.send(rx).await.is_err() {
                        break;
                    }
                }
                Err(e) => {
                    tracing::warn!("{e}");
                    tokio::time::sleep(Duration::from_millis(200)).await;
                }
            }
        }
    });
    let stop_at = setup.duration.map(|d| origin + d);
    // The operator dialog: questions from the replica's effects, answers
    // from stdin, sent signed.
    let mut signer = setup
        .operator
        .clone()
        .map(|key| petrel_core::signing::Signer::new(key, 0, None));
    let (lines_tx, mut lines) = mpsc::channel::<String>(16);
    let stdin_task = signer.is_some().then(|| {
        tokio::spawn(async move {
            use tokio::io::AsyncBufReadExt;
            let mut input = tokio::io::BufReader::new(tokio::io::stdin()).lines();
            while let Ok(Some(line)) = input.next_line().await {
                if lines_tx.send(line).await.is_err() {
                    break;
                }
            }
        })
    });
    let mut sent = 0u64;
    // Ticks on their own schedule: a sleep made anew at each turn of the
    // loop never ends while frames come faster than TICK (telemetry at
    // 50 Hz, or any rate at 10x), and then no request was ever retried
    // before the first downlink packet.
    let mut ticks = tokio::time::interval(clock.wall(TICK).max(Duration::from_millis(1)));
    ticks.set_missed_tick_behavior(tokio::time::MissedTickBehavior::Delay);
    loop {
        let until_stop = async {
            match stop_at {
                Some(t) => tokio::time::sleep_until(t.into()).await,
                None => std::future::pending().await,
            }
        };
        tokio::select! {
            Some(rx) = frames.recv() => {
                let now = clock.now();
                if let Some(rec) = &recorder {
                    rec.received(now, &rx.bytes);
                }
                if let Some(page) = &mut page {
                    page.frame(now, &rx.bytes);
                }
                station.handle_frame(now, &rx.bytes, crate::link::unix_us());
            }
            _ = ticks.tick() => station.handle_tick(clock.now()),
            Some(line) = lines.recv() => {
                let words: Vec<&str> = line.split_whitespace().collect();
                if let ["push", dir] = words[..] {
                    // Loaded, checked and packed off the loop.
                    let (dir, catalog, layers, tx) = (PathBuf::from(dir), setup.catalog.clone(), setup.layers.layers.clone(), pushes_tx.clone());
                    tokio::task::spawn_blocking(move || {
                        let _ = tx.send(push::prepare(&dir, &catalog, &layers).map_err(|e| format!("{e:?}")));
                    });
                    continue;
                }
                let pending: Vec<u64> = station.dialog().pending().map(|q| q.id).collect();
                let picked = match words[..] {
                    [id, choice] => id.trim_start_matches('#').parse::<u64>().ok().map(|id| (id, choice)),
                    [choice] if pending.len() == 1 => Some((pending[0], choice)),
                    _ => None,
                };
                match picked {
                    None => say!("answer as `ID CHOICE` (pending: {pending:?})"),
                    Some((id, choice)) => {
                        let sent = answer(&mut station, id, choice, signer.as_mut(), &uplink, clock.now(), recorder.as_ref()).await;
                        match &sent {
                            Ok(said) | Err(said) => say!("{said}"),
                        }
                        if let Some(page) = &page {
                            page.answered(id, choice, &sent);
                        }
                    }
                }
            }
            Some(request) = async {
                match &mut page_answers {
                    Some(answers) => answers.recv().await,
                    None => std::future::pending().await,
                }
            } => {
                // The page's answer: the same path as one typed on stdin.
                let petrel_web::monitor::answer::Request { id, choice, reply } = request;
                let sent = answer(&mut station, id, &choice, signer.as_mut(), &uplink, clock.now(), recorder.as_ref()).await;
                match &sent {
                    Ok(said) | Err(said) => say!("{said} (from the page)"),
                }
                if let Some(page) = &page {
                    page.answered(id, &choice, &sent);
                }
                let _ = reply.send(sent);
            }
            _ = signals.recv() => break,
            _ = until_stop => break,
            _ = hangups.recv() => {
                say!("SIGHUP: reading {} again for a version the vehicle may take over", setup.dir.display());
                let (dir, catalog, tx) = (setup.dir.clone(), setup.catalog.clone(), versions_tx.clone());
                tokio::task::spawn_blocking(move || {
                    let _ = tx.send(read_version(&dir, &catalog));
                });
            }
            Some(prepared) = pushes.recv() => match prepared {
                Ok(p) => {
                    say!("{}", p.summary(setup.push_rate));
                    push::start(&mut station, clock.now(), p, setup.push_rate);
                }
                Err(why) => say!("push: not sent:\n{why}"),
            },
            Some(read) = versions.recv() => match read {
                Ok(version) => {
                    say!(
                        "the replica follows the vehicle onto this version when it takes it over (files' digest {})",
                        hex8(&version.digest())
                    );
                    station.know(Arc::new(version));
                }
                Err(why) => say!("the folder read again does not load; the replica goes on:\n{why}"),
            },
        }
        let now = clock.now();
        // The version sent up: its pieces, signed, within its byte rate.
        if let Some(signer) = signer.as_mut() {
            while let Some((to, signed)) = station.poll_signed(now) {
                match uplink.send_signed(to, &signed, signer).await {
                    Ok(bytes) => {
                        if let Some(rec) = &recorder {
                            rec.sent(now, &bytes);
                        }
                    }
                    Err(e) => {
                        tracing::warn!("push: {e}");
                        break;
                    }
                }
            }
        }
        while let Some(output) = station.poll_output() {
            match output {
                Output::Upload(sent) => {
                    if let Some(text) = push::said(&sent, &mut pushed_tenth) {
                        say!("{text}");
                        if let Some(page) = &page {
                            page.pushed(&text);
                        }
                        if let Some(rec) = &recorder {
                            rec.log(now, petrel_record::recorder::Level::Info, "push", text);
                        }
                    }
                }
                Output::Report(report) => {
                    if let Some(rec) = &recorder {
                        rec.mirror(now, layout::MIRROR_REPLICA, report_json(&report, now));
                    }
                    if let Some(page) = &mut page {
                        page.report(&report);
                    }
                    if let Report::Version { version, .. } = &report {
                        printed = version.project.clone();
                    }
                    print_report(&mut out, &printed, &report, now);
                }
                Output::GapDetected { record, sent: at, detected_after } => {
                    if out.json {
                        let _ = writeln!(
                            out.out,
                            "{}",
                            json!({"mirror": "gap_detected", "record": record, "ground_t": now as f64 / 1e6, "sent_t": at as f64 / 1e6, "detected_after_s": detected_after as f64 / 1e6})
                        );
                    }
                }
                Output::Played(played) => {
                    if let Some(rec) = &recorder {
                        if let petrel_core::mirror::call::Call::Version(v) = &played.call {
                            rec.replica_version(v.project.clone());
                        }
                        calls += 1;
                        let step = petrel_core::supervisor::Step {
                            seq: calls,
                            time: played.time,
                            events: Vec::new(),
                            effects: played.effects,
                        };
                        rec.replica(now, call_json(&played.call), step, played.digest);
                    }
                }
                Output::Disagreement(d) => {
                    if let Some(page) = &mut page {
                        page.disagreement(&d);
                    }
                    disagreement(&mut out, recorder.as_ref(), &d, now, station.replica().vehicle_time(now));
                }
                Output::Question { question: q, first, left } => {
                    if first {
                        if let Some(rec) = &recorder {
                            rec.mirror(now, layout::MIRROR_DIALOG, json!({"time_us": now, "kind": "question", "id": q.id, "net": q.net, "question": q.question, "choices": q.choices, "deadline_us": q.deadline}));
                        }
                        say!(
                            "QUESTION #{} from {}: {}  choices: {}  (answer `{} CHOICE`)",
                            q.id,
                            q.net,
                            q.question,
                            q.choices.join(" / "),
                            q.id
                        );
                    }
                    say!("QUESTION #{}: {left} s left", q.id);
                }
                Output::Refused { system, why } => say!(
                    "petrel mirror: a downlink record from system {system} refused: {why} (the downlink must be signed with --signing-key's key; every refusal is counted)"
                ),
                Output::NothingHeard => say!(
                    "petrel mirror: nothing heard on {} after {} s. Check the address, and that mavlink-router or MAVProxy (--out) sends the ground's telemetry there (docs/mirror.md, \"Deploying it\").",
                    setup.address,
                    SILENCE_WARNING / 1_000_000
                ),
                Output::NoDownlink { vehicle } => say!(
                    "petrel mirror: the vehicle (system {vehicle}) is heard but no downlink record after {} s. Is `petrel run --downlink` running on board, and does the autopilot route to this mirror (system {})? (docs/mirror.md, \"Addressing\")",
                    2 * SILENCE_WARNING / 1_000_000,
                    setup.system
                ),
                Output::Foreign { system } => say!(
                    "petrel mirror: system {system} is heard but is no vehicle of the team: its frames are not followed as a vehicle's"
                ),
            }
        }
        // Requests wait in the station until there is someone to ask.
        while let Some((to, request)) = station.poll_transmit() {
            match uplink.send(to, &request).await {
                Ok(bytes) => {
                    sent += 1;
                    if let Some(rec) = &recorder {
                        rec.sent(now, &bytes);
                    }
                }
                Err(e) => tracing::warn!("uplink: {e}"),
            }
        }
        // The page last, off the path from a packet to its request.
        if let Some(page) = &mut page {
            if let Some(s) = station.signed() {
                page.signatures(s.refusals());
            }
            page.settle(now, station.replica(), station.dialog(), station.ground());
        }
        let _ = out.out.flush();
    }
    reader_task.abort();
    if let Some(t) = stdin_task {
        t.abort();
    }
    let (ground, replica) = (station.ground(), station.replica());
    let total = ground.total();
    let blind = ground.blind(|t| replica.vehicle_time(t));
    let (followed, blind_for) = blind
        .iter()
        .fold((0, 0), |(f, b), (f1, b1)| (f + f1, b + b1));
    say!(
        "independent check: {} events matched (the vehicle at most {:.2} s after the ground, the ground at most {:.2} s after the vehicle), {} seen by the ground only, {} by the vehicle only, {} not judged (ground losing frames, or settling), {} unobservable on the ground (every rule reads a message it does not receive), {} link events and {} addressed to one link not compared; blind to ground events {:.1} s of {:.1} s followed",
        total.matched,
        total.vehicle_late_max as f64 / 1e6,
        total.ground_late_max as f64 / 1e6,
        total.ground_only,
        total.vehicle_only,
        total.unjudged,
        total.unobservable,
        total.skipped,
        total.addressed,
        blind_for as f64 / 1e6,
        followed as f64 / 1e6
    );
    if ground.team() {
        for (w, c) in ground.watches().iter().zip(ground.counts()) {
            say!(
                "  {} (system {}): {} frames, {} events matched, {} ground only, {} vehicle only, {} not judged, {} unobservable",
                w.name.as_deref().unwrap_or("?"),
                w.system.map_or("?".to_owned(), |s| s.to_string()),
                w.frames,
                c.matched,
                c.ground_only,
                c.vehicle_only,
                c.unjudged,
                c.unobservable
            );
        }
        for (system, frames) in ground.foreign() {
            say!("  system {system}, no vehicle of the team: {frames} frames not followed");
        }
    }
    let c = &replica.counts;
    say!(
        "mirror stopped after {:.1} s: {} downlink packets ({} refused), {} records, {} checks agreed, {} gaps, {} resends, {} snapshots and {} heartbeats asked, {} snapshots restored, {} divergences; {} requests sent; {} ground events",
        origin.elapsed().as_secs_f64(),
        c.packets,
        c.refused,
        c.records,
        c.agreed,
        c.gaps,
        c.resends_asked,
        c.snapshots_asked,
        c.heartbeats_asked,
        c.snapshots_restored,
        c.diverged,
        sent,
        ground.events,
    );
    let signatures = station.signed().map(|s| s.refusals());
    if let Some(r) = &signatures {
        say!(
            "downlink signatures: {} frames signed with the key, {}",
            r.accepted,
            r.words()
        );
    }
    if out.json {
        let mut summary = summary_json(ground, replica, sent, &blind);
        summary["signatures"] = json!(signatures);
        let _ = writeln!(out.out, "{summary}");
    }
    if let Some(rec) = recorder {
        let dropped = rec.dropped();
        match rec.finish() {
            Ok(report) if report.dropped > 0 => say!(
                "recorded {} steps; the recorder fell behind and dropped {} entries ({} steps): replay stops at the first",
                report.steps, report.dropped, report.dropped_steps
            ),
            Ok(report) => say!("recorded {} steps, {} messages", report.steps, report.messages),
            Err(e) => say!("the recording stopped ({e}); {dropped} entries were not recorded"),
        }
    }
    if let Some((player, provisional)) = replica.shown() {
        let _ = out.end(player.state().now, player);
        if provisional {
            say!("the replica ends provisional: records were missing at the end");
        }
    }
    let _ = out.out.flush();
    Ok(if c.diverged > 0 {
        super::Outcome::Failed
    } else {
        super::Outcome::Success
    })
}

/// The closing summary (`--json`): each vehicle's frames received and its
/// independent check, systems heard that are no vehicle of the team, and
/// the replica's counts.
fn summary_json(
    ground: &Ground,
    replica: &Replica,
    sent: u64,
    blind: &[(Micros, Micros)],
) -> serde_json::Value {
    let vehicles: Vec<serde_json::Value> = ground
        .watches()
        .iter()
        .zip(ground.counts())
        .zip(blind)
        .map(|((w, c), (followed, blind))| {
            json!({
                "vehicle": w.name, "system": w.system, "frames": w.frames, "heard": w.heard,
                "matched": c.matched, "ground_only": c.ground_only, "vehicle_only": c.vehicle_only,
                "unjudged": c.unjudged, "unobservable": c.unobservable,
                "skipped": c.skipped, "addressed": c.addressed,
                "followed_s": *followed as f64 / 1e6, "blind_s": *blind as f64 / 1e6,
                "vehicle_late_max_s": c.vehicle_late_max as f64 / 1e6,
                "ground_late_max_s": c.ground_late_max as f64 / 1e6,
            })
        })
        .collect();
    let foreign: serde_json::Map<String, serde_json::Value> = ground
        .foreign()
        .iter()
        .map(|(s, n)| (s.to_string(), json!(n)))
        .collect();
    let c = &replica.counts;
    json!({
        "summary": "mirror",
        "vehicles": vehicles,
        "foreign": foreign,
        "ground_events": ground.events,
        "packets": c.packets, "records": c.records, "agreed": c.agreed, "gaps": c.gaps,
        "diverged": c.diverged, "snapshots_restored": c.snapshots_restored, "requests_sent": sent,
    })
}

/// The operator's answer `choice` to question `id`, typed on stdin or
/// clicked in the page: checked by the station, sent up signed with the
/// operator key, recorded; what to say, or why it was not sent.
async fn answer(
    station: &mut Station,
    id: u64,
    choice: &str,
    signer: Option<&mut petrel_core::signing::Signer>,
    uplink: &UplinkWriter,
    now: Micros,
    recorder: Option<&Recorder>,
) -> Result<String, String> {
    let to = station.answer(now, id, choice)?;
    let Some(signer) = signer else {
        return Err(format!("answer #{id} not sent: no operator key"));
    };
    match uplink.send_answer(to, id, choice, signer).await {
        Ok(bytes) => {
            if let Some(rec) = recorder {
                rec.sent(now, &bytes);
                rec.mirror(
                    now,
                    layout::MIRROR_DIALOG,
                    json!({"time_us": now, "kind": "answer_sent", "id": id, "choice": choice}),
                );
            }
            Ok(format!("answer #{id} {choice} sent (signed)"))
        }
        Err(e) => Err(format!("answer #{id} not sent: {e}")),
    }
}

/// A disagreement of the independent check: recorded, printed (`--json`:
/// with when it was reported, in vehicle time).
fn disagreement<W: Write>(
    out: &mut Timeline<W>,
    recorder: Option<&Recorder>,
    d: &Disagreement,
    now: Micros,
    reported: Option<Micros>,
) {
    let event = d.event();
    tracing::warn!("{event}");
    if let Some(rec) = recorder {
        let mut v = json!({"time_us": now});
        for (k, val) in &event.params {
            v[k] = val.to_json();
        }
        rec.mirror(now, layout::MIRROR_CHECK, v);
    }
    if out.json {
        let mut v = json!({"mirror": event.name, "ground_t": now as f64 / 1e6});
        for (k, val) in &event.params {
            v[k] = val.to_json();
        }
        if let Some(t) = reported {
            v["reported_t"] = json!(t as f64 / 1e6);
        }
        let _ = writeln!(out.out, "{v}");
    } else {
        let _ = writeln!(out.out, "mirror: {event}");
    }
}

/// A report as recorded on `/mirror/replica`; `now` is the ground's time.
fn report_json(report: &Report, now: Micros) -> serde_json::Value {
    match report {
        Report::Step {
            number,
            step,
            time,
            inputs,
            ..
        } => {
            json!({"time_us": now, "report": "step", "record": number, "step": step, "vehicle_time_us": time, "inputs": inputs.len()})
        }
        Report::Timers {
            step,
            time,
            effects,
        } => {
            json!({"time_us": now, "report": "timers", "step": step, "vehicle_time_us": time, "effects": effects.len()})
        }
        Report::Agreed { step } => json!({"time_us": now, "report": "agreed", "step": step}),
        Report::Version { number, step, .. } => {
            json!({"time_us": now, "report": "version", "number": number, "step": step})
        }
        Report::UnknownVersion { number, digest } => {
            json!({"time_us": now, "report": "unknown_version", "number": number, "digest": hex8(digest)})
        }
        Report::Gap { from, to, step } => {
            json!({"time_us": now, "report": "gap", "from": from, "to": to, "step": step})
        }
        Report::Resynced { .. } | Report::Diverged { .. } => {
            let mut v = json!({"time_us": now});
            if let Some(event) = report.event() {
                v["report"] = json!(event.name);
                for (k, val) in &event.params {
                    v[k] = val.to_json();
                }
            }
            v
        }
    }
}

/// A report; `now` is the ground's time (`ground_t` in JSON).
fn print_report<W: Write>(out: &mut Timeline<W>, project: &Project, report: &Report, now: Micros) {
    let ground_t = now as f64 / 1e6;
    match report {
        Report::Step {
            number,
            step,
            time,
            inputs,
            effects,
        } => {
            for input in inputs {
                match input {
                    Input::Elaborated { time, event, .. }
                    | Input::Program { time, event }
                    | Input::Answer { time, event } => {
                        let _ = out.event(
                            project,
                            *time,
                            event,
                            Some(json!({"vehicle_step": step, "record": number})),
                        );
                    }
                    Input::Result { time, id, outcome } => {
                        let (ok, text) = match outcome {
                            nets::Outcome::Done(_) => (true, "done".to_owned()),
                            nets::Outcome::Failed(r) => (false, format!("failed: {r}")),
                        };
                        let _ = out.input(
                            *time,
                            "reply",
                            json!({"id": id, "ok": ok, "vehicle_step": step, "record": number}),
                            &format!("REPLY  #{id} {text}"),
                        );
                    }
                    Input::Answered { time, id, choice } => {
                        let _ = out.input(
                            *time,
                            "answer",
                            json!({"id": id, "choice": choice, "vehicle_step": step, "record": number}),
                            &format!("ANSWER #{id} {choice}"),
                        );
                    }
                    Input::Version {
                        time,
                        number: version,
                        ..
                    } => {
                        let _ = out.input(
                            *time,
                            "version",
                            json!({"version": version, "vehicle_step": step, "record": number}),
                            &format!("VERSION {version} takes over"),
                        );
                    }
                }
            }
            let _ = time;
            let _ = out.effects(project, effects);
        }
        Report::Timers { effects, .. } => {
            let _ = out.effects(project, effects);
        }
        Report::Agreed { step } => {
            if out.json {
                let _ = writeln!(
                    out.out,
                    "{}",
                    json!({"mirror": "agreed", "step": step, "ground_t": ground_t})
                );
            }
        }
        Report::Version { number, step, .. } => {
            let _ = writeln!(
                out.out,
                "{}",
                if out.json {
                    json!({"mirror": "version", "number": number, "step": step, "ground_t": ground_t}).to_string()
                } else {
                    format!("mirror: the vehicle took over version {number} at step {step}, and the replica with it")
                }
            );
        }
        Report::UnknownVersion { number, digest } => {
            let text = format!(
                "the vehicle took over version {number} (files' digest {}), which this mirror does not have: the replica waits for it; copy the version into {} and send the mirror SIGHUP",
                hex8(digest),
                "the mirror's project folder"
            );
            tracing::warn!("{text}");
            let _ = writeln!(
                out.out,
                "{}",
                if out.json {
                    json!({"mirror": "unknown_version", "number": number, "digest": hex8(digest), "ground_t": ground_t}).to_string()
                } else {
                    format!("mirror: {text}")
                }
            );
        }
        Report::Gap { from, to, step } => {
            let _ = writeln!(
                out.out,
                "{}",
                if out.json {
                    json!({"mirror": "gap", "from": from, "to": to, "step": step, "ground_t": ground_t}).to_string()
                } else {
                    format!("mirror: records {from}..{to} missing after step {step}: the replica is provisional")
                }
            );
        }
        Report::Resynced { .. } | Report::Diverged { .. } => {
            if let Some(event) = report.event() {
                match report {
                    Report::Diverged { .. } => tracing::warn!("{event}"),
                    _ => tracing::info!("{event}"),
                }
                if out.json {
                    let mut v = json!({"mirror": event.name, "ground_t": ground_t});
                    for (k, val) in &event.params {
                        v[k] = val.to_json();
                    }
                    let _ = writeln!(out.out, "{v}");
                } else {
                    let _ = writeln!(out.out, "mirror: {event}");
                }
            }
        }
    }
}

/// The first 8 bytes of a digest, in hex.
fn hex8(digest: &[u8]) -> String {
    digest.iter().take(8).map(|b| format!("{b:02x}")).collect()
}
