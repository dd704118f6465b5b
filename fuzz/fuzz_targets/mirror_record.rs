//! The ground mirror's records (`petrel_core::mirror::record`) and the player snapshot a resync restores
//! (nets::player::snapshot over nets::binary): any bytes as a downlink or
//! uplink packet, as a step record joined from fragments, and as a snapshot
//! joined from chunks, restored onto the flight-test example's player and
//! played on. Seeds: `cargo run --example mirror_record_seeds` (real
//! records from a publisher fed the nominal flight).
#![no_main]

use libfuzzer_sys::fuzz_target;
use nets::binary::{Reader, Writer};
use nets::player::snapshot;
use nets::{Event, Outcome, Player};

use petrel_core::mirror::record;

#[path = "../shared/flight_test.rs"]
mod flight_test;

fuzz_target!(|data: &[u8]| {
    // A packet, as the replica and the publisher decode it. What decodes
    // encodes again to bytes that decode to the same encoding.
    if let Ok(records) = record::decode_packet(data) {
        let once = record::packet(&records);
        let again = record::decode_packet(&once).expect("a re-encoded packet decodes");
        assert_eq!(record::packet(&again), once, "re-encoding is stable");
        for r in &records {
            let _ = record::size(r);
        }
    }
    // A step record's body, as fragments join into it.
    let mut r = Reader::new(data);
    if let Ok(step) = record::decode_step(&mut r).and_then(|s| r.finish().map(|()| s)) {
        let mut w = Writer::new();
        record::step_body(&step, &mut w);
        let mut back = Reader::new(&w.bytes);
        let again = record::decode_step(&mut back).expect("a re-encoded step decodes");
        let mut w2 = Writer::new();
        record::step_body(&again, &mut w2);
        assert_eq!(w2.bytes, w.bytes, "re-encoding a step is stable");
    }
    // A snapshot, as chunks join into it (of the first version, and of a
    // version that took over in flight); and the player's state alone.
    for versioned in [false, true] {
        if let Ok(s) = record::Snapshot::decode(data, versioned) {
            assert_eq!(s.version.is_some(), versioned);
            restore(&s.state);
        }
    }
    restore(data);
});

/// Decodes a player state and, the digest aside (a hostile downlink can
/// compute it), restores it on the flight-test project and plays on: the
/// player must refuse a state that does not fit, or run with it.
fn restore(bytes: &[u8]) {
    let Ok(state) = snapshot::decode(bytes) else {
        return;
    };
    let _ = snapshot::digest(&state);
    let again = snapshot::encode(&state);
    assert_eq!(
        snapshot::encode(&snapshot::decode(&again).expect("a re-encoded snapshot decodes")),
        again,
        "re-encoding a snapshot is stable"
    );
    let Some(project) = flight_test::project() else {
        return;
    };
    let Ok(mut player) = Player::restore(project, state) else {
        return;
    };
    let _ = player.effects().count();
    let now = player.state().now;
    let pending: Vec<u64> = player.state().pending.keys().copied().collect();
    for id in pending {
        player.result(id, Outcome::Failed("fuzz".into()), now);
        let _ = player.effects().count();
    }
    for name in ["link_lost", "engine_failure", "takeoff", "landed"] {
        player.handle(&Event::new(name), now.saturating_add(1));
        let _ = player.effects().count();
    }
    if let Some(t) = player.next_deadline() {
        player.advance(t);
    }
    player.advance(now.saturating_add(3_600_000_000));
    let _ = player.effects().count();
    let _ = player.digest();
}
