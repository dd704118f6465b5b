//! Writes `fuzz/corpus/mirror_record/`: real downlink and uplink packets,
//! a step record's body and a whole snapshot, from the gateway's own
//! publisher (core/src/mirror/publisher.rs) fed the flight-test
//! example's nominal script, played on its player.
//!
//! ```sh
//! cd fuzz && cargo run --example mirror_record_seeds
//! ```

use std::path::Path;

use nets::binary::Writer;
use nets::script::{self, Input as ScriptInput};

#[path = "../shared/flight_test.rs"]
mod flight_test;
use petrel_core::mirror::publisher;
use petrel_core::mirror::record::{self, Input, Record};

fn main() -> Result<(), Box<dyn std::error::Error>> {
    let out = Path::new(env!("CARGO_MANIFEST_DIR")).join("corpus/mirror_record");
    std::fs::create_dir_all(&out)?;
    let project = flight_test::project().ok_or("the flight-test example does not load")?;
    let text = include_str!("../../examples/uav-flight-test/scripts/nominal.jsonl");
    let lines = script::parse(text)?;
    let mut player = nets::Player::start(project, 0);
    let _ = player.effects().count();
    let mut publisher = publisher::Publisher::new(7, publisher::Config::default(), 0);
    let mut packets: Vec<Vec<u8>> = Vec::new();
    let mut bodies: Vec<Vec<u8>> = Vec::new();
    for (step, line) in lines.iter().enumerate() {
        let before = player.state().now;
        let input = match &line.input {
            ScriptInput::Event(e) => Some(Input::Program {
                time: line.time,
                event: e.clone(),
            }),
            ScriptInput::Reply { to, outcome } => {
                player.advance(line.time);
                let id = script::resolve(&player, line, to)?;
                Some(Input::Result {
                    time: line.time,
                    id,
                    outcome: outcome.clone(),
                })
            }
            // The nominal script asks the operator nothing.
            ScriptInput::Answer { .. } | ScriptInput::Advance => None,
        };
        script::play_line(&mut player, line)?;
        let _ = player.effects().count();
        if let Some(input) = input {
            let s = record::StepRecord {
                number: 0,
                step: step as u64,
                before,
                time: line.time,
                inputs: vec![input.clone()],
                digest: [0; 8],
            };
            let mut w = Writer::new();
            record::step_body(&s, &mut w);
            bodies.push(w.bytes);
            publisher.step(
                step as u64,
                before,
                line.time,
                vec![input],
                &player.digest(),
            );
        }
        if step == lines.len() / 2 {
            // The ground asks for records again, for a snapshot and for a
            // heartbeat once the vehicle's time is a second on.
            let ask = record::packet(&[
                Record::Resend { from: 2, count: 4 },
                Record::SendSnapshot { session: 7 },
                Record::SendHeartbeat {
                    at: line.time + 1_000_000,
                },
            ]);
            packets.push(ask.clone());
            publisher.receive(&ask);
        }
        publisher.tick(line.time, step as u64, &player);
        while let Some(p) = publisher.poll_transmit() {
            packets.push(p);
        }
    }
    // The operator's answer to question 5: `01 07 05 03 79 65 73`.
    packets.push(record::packet(&[Record::Answer {
        id: 5,
        choice: "yes".into(),
    }]));
    // Kinds of packet, one file each (the first of each kind, and the
    // longest step body), so that the corpus stays small.
    let mut kept = std::collections::BTreeMap::new();
    for p in &packets {
        let records = record::decode_packet(p)?;
        let kind = match &records[0] {
            Record::Step(_) if records.len() > 1 => "steps",
            Record::Step(_) => "step",
            Record::Heartbeat(_) if records.len() > 1 => "heartbeat-and-steps",
            Record::Heartbeat(_) => "heartbeat",
            Record::Fragment(_) => "fragment",
            Record::Chunk(_) => "chunk",
            Record::Resend { .. }
            | Record::SendSnapshot { .. }
            | Record::SendHeartbeat { .. } => "uplink",
            Record::Answer { .. } => "answer",
            Record::Boot { .. } => "boot",
            Record::Upload { .. }
            | Record::Piece { .. }
            | Record::Received { .. }
            | Record::Verdict { .. } => "upload",
        };
        kept.entry(kind).or_insert_with(|| p.clone());
    }
    for (kind, p) in &kept {
        std::fs::write(out.join(format!("packet-{kind}")), p)?;
    }
    if let Some(b) = bodies.iter().max_by_key(|b| b.len()) {
        std::fs::write(out.join("step-body"), b)?;
    }
    let snapshot = record::Snapshot {
        step: lines.len() as u64,
        next: 0,
        version: None,
        digest: player.digest().0,
        state: nets::player::snapshot::encode(player.state()),
    };
    std::fs::write(out.join("snapshot"), snapshot.encode())?;
    let mut early = nets::Player::start(flight_test::project().ok_or("no project")?, 0);
    let _ = early.effects().count();
    std::fs::write(
        out.join("player-state-at-start"),
        nets::player::snapshot::encode(early.state()),
    )?;
    println!("{} files in {}", kept.len() + 3, out.display());
    Ok(())
}
