//! The verifier's restore ([`Player::reset_for_verifier`]) puts back
//! exactly the state it is given, whatever the steps since the last one
//! did to the pending calls (it copies only what they changed).

use std::collections::BTreeMap;
use std::sync::Arc;

use super::{Outcome, Player, State};
use crate::value::Params;

/// Net `N`: `go` issues two commands; a `command.ok` moves it on.
fn player() -> Player {
    let files: BTreeMap<String, String> = [
        (
            "project.toml",
            "[[net]]\nfile = \"n.toml\"\nactive = true\n",
        ),
        (
            "n.toml",
            "name = \"N\"\nplaces = [\"a\", \"b\", \"c\"]\ninitial = [\"a\"]\n\
             [[transition]]\nname = \"issue\"\nfrom = [\"a\"]\nto = [\"b\"]\non = \"go\"\n\
             do = [\"command arm\", \"command disarm\"]\n\
             [[transition]]\nname = \"done\"\nfrom = [\"b\"]\nto = [\"c\"]\non = \"command.ok\"\n",
        ),
    ]
    .into_iter()
    .map(|(n, t)| (n.to_owned(), t.to_owned()))
    .collect();
    let project = crate::load::load(&files).unwrap_or_else(|e| panic!("{e}"));
    Player::start(Arc::new(project), 0)
}

#[test]
fn the_verifiers_restore_puts_back_the_pending_calls_a_step_changed() {
    let mut player = player();
    player.handle(&crate::event::Event::new("go"), 1);
    let issued: State = player.snapshot();
    assert_eq!(issued.pending.len(), 2, "two commands pending");
    // The same state as `issued` with `a` marked again: `go` issues two more.
    let mut again = issued.clone();
    let a = player.project().place_offsets[0];
    again.set(a, true);
    again.set(a + 1, false);

    // A result removes a call; the restore puts it back.
    player.reset_for_verifier(&issued, 7, &[]);
    player.result(1, Outcome::Done(Params::new()), 2);
    assert_eq!(player.state().pending.len(), 1);
    player.reset_for_verifier(&issued, 7, &[]);
    assert_eq!(player.state(), &issued);

    // A step adds calls (same pending calls, another state); the restore
    // drops them.
    player.reset_for_verifier(&again, 7, &[]);
    player.handle(&crate::event::Event::new("go"), 2);
    assert_eq!(player.state().pending.len(), 4);
    player.reset_for_verifier(&again, 7, &[]);
    assert_eq!(player.state(), &again);

    // Both in one step, then other pending calls (another number): a copy.
    player.reset_for_verifier(&again, 7, &[]);
    player.result(2, Outcome::Done(Params::new()), 2);
    player.handle(&crate::event::Event::new("go"), 2);
    player.reset_for_verifier(&issued, 7, &[]);
    assert_eq!(player.state(), &issued);
    let mut fewer = issued.clone();
    fewer.pending.remove(&1);
    player.reset_for_verifier(&fewer, 8, &[]);
    assert_eq!(player.state(), &fewer);
    player.reset_for_verifier(&issued, 9, &[]);
    assert_eq!(player.state(), &issued);
}
