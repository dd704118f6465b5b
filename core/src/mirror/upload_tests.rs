//! An upload between the ground's sender and the vehicle's receiver, over
//! a lossy, reordering link in simulated time.

use super::*;

/// Moves packets both ways every 10 ms for at most `max_s` seconds,
/// losing one in `lose_every` (0: none) each way; the time the vehicle
/// had it whole, or `None`.
fn run(
    sender: &mut Sender,
    receiver: &mut Receiver,
    lose_every: u64,
    max_s: u64,
) -> Option<Micros> {
    let mut n = 0u64;
    let lose = |n: &mut u64| {
        *n += 1;
        lose_every > 0 && n.is_multiple_of(lose_every)
    };
    let mut whole = None;
    for step in 1..=max_s * 100 {
        let t = step * 10_000;
        while let Some(signed) = sender.poll_transmit(t) {
            if lose(&mut n) {
                continue;
            }
            for r in record::decode_packet(signed.bytes()).expect("a packet") {
                receiver.handle(t, r);
            }
        }
        receiver.tick(t);
        if let Some((_, bytes)) = receiver.poll_complete() {
            whole = Some(t);
            receiver.verdict(
                sender.upload(),
                &format!("took over at step {}", bytes.len()),
            );
        }
        while let Some(r) = receiver.poll_downlink() {
            if !lose(&mut n) {
                sender.handle(t, &r);
            }
        }
        sender.tick(t);
        if sender.done() {
            break;
        }
    }
    whole
}

fn bytes(n: usize) -> Vec<u8> {
    (0..n).map(|i| (i * 7 + i / 256) as u8).collect()
}

#[test]
fn an_upload_arrives_whole_at_its_rate_and_the_verdict_comes_back() {
    let data = bytes(10_000);
    let mut sender = Sender::new(7, data.clone(), 0, Config::default());
    let mut receiver = Receiver::new(Config::default());
    let whole = run(&mut sender, &mut receiver, 0, 60).expect("it arrives");
    // 105 pieces of about 100 bytes at 1,000 B/s: about 11 s.
    assert!((9_000_000..14_000_000).contains(&whole), "{whole}");
    let reports: Vec<Sent> = std::iter::from_fn(|| sender.poll_report()).collect();
    assert!(reports.contains(&Sent::Verdict {
        text: "took over at step 10000".into()
    }));
    assert!(reports.iter().any(|r| matches!(r, Sent::Delivered { .. })));
    assert_eq!(receiver.counts.completed, 1);
    assert!(sender.sent_bytes < 11_500, "{}", sender.sent_bytes);
}

#[test]
fn a_tenth_of_the_packets_lost_costs_their_retransmission_only() {
    let data = bytes(10_000);
    let mut sender = Sender::new(8, data.clone(), 0, Config::default());
    let mut receiver = Receiver::new(Config::default());
    let mut got = None;
    let whole = {
        let mut n = 0u64;
        let mut t = 0;
        let mut whole = None;
        while t < 120_000_000 && !sender.done() {
            t += 10_000;
            while let Some(signed) = sender.poll_transmit(t) {
                n += 1;
                if n.is_multiple_of(10) {
                    continue;
                }
                for r in record::decode_packet(signed.bytes()).expect("a packet") {
                    receiver.handle(t, r);
                }
            }
            receiver.tick(t);
            if let Some((_, b)) = receiver.poll_complete() {
                got = Some(b);
                whole = Some(t);
                receiver.verdict(8, "took over");
            }
            while let Some(r) = receiver.poll_downlink() {
                n += 1;
                if !n.is_multiple_of(10) {
                    sender.handle(t, &r);
                }
            }
            sender.tick(t);
        }
        whole
    };
    assert_eq!(
        got.as_deref(),
        Some(&data[..]),
        "the bytes, whole and in order"
    );
    let whole = whole.expect("it arrives");
    assert!(whole < 25_000_000, "{whole}");
    // The lost tenth is sent again, little more.
    assert!(sender.sent_bytes < 14_000, "{}", sender.sent_bytes);
    assert!(sender.done());
}

#[test]
fn altered_bytes_are_refused_and_nothing_is_handed_on() {
    let data = bytes(1_000);
    let mut receiver = Receiver::new(Config::default());
    let digest: [u8; 32] = Sha256::digest(&data).into();
    receiver.handle(
        0,
        Record::Upload {
            upload: 1,
            length: 1_000,
            digest,
        },
    );
    for (i, piece) in data.chunks(PIECE).enumerate() {
        let mut piece = piece.to_vec();
        if i == 3 {
            piece[0] ^= 1;
        }
        receiver.handle(
            10,
            Record::Piece {
                upload: 1,
                index: i as u64,
                data: piece,
            },
        );
    }
    assert!(receiver.poll_complete().is_none());
    assert_eq!(receiver.counts.altered, 1);
    let said: Vec<Record> = std::iter::from_fn(|| receiver.poll_downlink()).collect();
    assert!(
        said.iter()
            .any(|r| matches!(r, Record::Verdict { text, .. } if text.contains("do not hash"))),
        "{said:?}"
    );
}

#[test]
fn a_second_upload_while_one_is_received_is_refused_by_name() {
    let mut receiver = Receiver::new(Config::default());
    let offer = |upload| Record::Upload {
        upload,
        length: 500,
        digest: [0; 32],
    };
    receiver.handle(0, offer(1));
    receiver.handle(1_000_000, offer(2));
    assert_eq!(receiver.counts.busy, 1);
    let said: Vec<Record> = std::iter::from_fn(|| receiver.poll_downlink()).collect();
    assert!(
        said.iter().any(|r| matches!(r, Record::Verdict { upload: 2, text, .. } if text.contains("upload 1 is being received"))),
        "{said:?}"
    );
    // Once the first went silent long enough, another may start.
    receiver.tick(61_000_000);
    receiver.handle(61_000_000, offer(3));
    assert_eq!(receiver.counts.busy, 1);
}

#[test]
fn bad_offers_and_pieces_are_refused_and_counted_never_grown() {
    let mut receiver = Receiver::new(Config::default());
    receiver.handle(
        0,
        Record::Upload {
            upload: 1,
            length: MAX_LENGTH + 1,
            digest: [0; 32],
        },
    );
    receiver.handle(
        0,
        Record::Upload {
            upload: 2,
            length: 200,
            digest: [0; 32],
        },
    );
    for (index, len) in [(u64::MAX, 96), (3, 96), (0, 95), (1, 96), (9, 8)] {
        receiver.handle(
            0,
            Record::Piece {
                upload: 2,
                index,
                data: vec![0; len],
            },
        );
    }
    // Only the right-sized piece 1 was taken.
    assert_eq!(receiver.counts.pieces, 1);
    assert_eq!(receiver.counts.refused, 5);
    receiver.handle(
        0,
        Record::Piece {
            upload: 99,
            index: 0,
            data: vec![0; 96],
        },
    );
    assert_eq!(receiver.counts.refused, 6);
}

#[test]
fn a_link_that_never_answers_is_given_up() {
    let mut sender = Sender::new(5, bytes(300), 0, Config::default());
    let mut t = 0;
    let mut offers = 0;
    while !sender.done() && t < 100_000_000 {
        t += 10_000;
        while let Some(s) = sender.poll_transmit(t) {
            if matches!(
                record::decode_packet(s.bytes()).as_deref(),
                Ok([Record::Upload { .. }])
            ) {
                offers += 1;
            }
        }
        sender.tick(t);
    }
    assert!((59_000_000..=61_000_000).contains(&t), "{t}");
    assert!(offers >= 20, "the offer goes again every 2 s: {offers}");
    assert!(matches!(sender.poll_report(), Some(Sent::GaveUp { .. })));
}

#[test]
fn files_travel_as_bytes_and_paths_stay_inside_the_project() {
    let files = vec![
        ("project.toml".to_owned(), "name = \"p\"\n".to_owned()),
        ("nets/a.toml".to_owned(), "é\n".to_owned()),
    ];
    assert_eq!(files_from(&files_bytes(&files)), Ok(files));
    for bad in ["/etc/passwd", "../x.toml", "a//b", "a/../b", ""] {
        let b = files_bytes(&[(bad.to_owned(), String::new())]);
        assert!(files_from(&b).is_err(), "{bad}");
    }
    assert!(files_from(&[0xff, 0xff]).is_err());
}

#[test]
fn a_long_proof_keeps_the_ground_waiting_for_the_verdict_not_giving_up() {
    let data = bytes(500);
    let mut sender = Sender::new(9, data, 0, Config::default());
    let mut receiver = Receiver::new(Config::default());
    let mut t = 0;
    let mut verdict_at = None;
    while !sender.done() && t < 300_000_000 {
        t += 10_000;
        while let Some(signed) = sender.poll_transmit(t) {
            for r in record::decode_packet(signed.bytes()).expect("a packet") {
                receiver.handle(t, r);
            }
        }
        receiver.tick(t);
        let _ = receiver.poll_complete();
        // The vehicle proves it for two minutes.
        if t == 150_000_000 {
            receiver.verdict(9, "version 1 took over at step 7");
            verdict_at = Some(t);
        }
        while let Some(r) = receiver.poll_downlink() {
            sender.handle(t, &r);
        }
        sender.tick(t);
    }
    let reports: Vec<Sent> = std::iter::from_fn(|| sender.poll_report()).collect();
    assert!(
        reports.contains(&Sent::Verdict {
            text: "version 1 took over at step 7".into()
        }),
        "{:?}",
        reports
            .iter()
            .filter(|r| !matches!(r, Sent::Progress { .. }))
            .collect::<Vec<_>>()
    );
    assert_eq!(verdict_at, Some(t));
}
