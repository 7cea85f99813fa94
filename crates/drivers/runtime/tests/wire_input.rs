//! Whatever arrives on the wire, a node gets a message or an error, never a panic: random bytes,
//! and valid messages with bytes flipped or cut.

use madenet_agent::Beta;
use madenet_map::{Occupancy, Pos};
use madenet_runtime::wire::{BetaMessage, Body, Envelope, Node};
use proptest::prelude::*;

fn beta_envelope() -> Vec<u8> {
    let beta = Beta {
        from: 1,
        t: 4,
        prev_goal: Some(Pos::new(2, 3)),
        pos: Pos::new(1, 1),
        goal: None,
        map: vec![Occupancy::Free; 400],
        explored: 12,
    };
    let old = vec![Occupancy::Unknown; 400];
    let msg = BetaMessage::new(&beta, Some((2, &old)), true);
    Envelope::new(4, Node::Robot(1), Node::Robot(0), Body::Beta(msg)).encode()
}

proptest! {
    #[test]
    fn random_bytes_decode_to_a_message_or_an_error(bytes in proptest::collection::vec(any::<u8>(), 0..2048)) {
        let _ = Envelope::decode(&bytes);
    }

    #[test]
    fn damaged_messages_decode_to_a_message_or_an_error(
        flips in proptest::collection::vec((any::<prop::sample::Index>(), any::<u8>()), 1..8),
        cut in any::<prop::sample::Index>(),
    ) {
        let mut bytes = beta_envelope();
        for (at, v) in flips {
            let k = at.index(bytes.len());
            bytes[k] ^= v;
        }
        let keep = cut.index(bytes.len() + 1);
        bytes.truncate(keep);
        if let Ok(Envelope { body: Body::Beta(m), .. }) = Envelope::decode(&bytes) {
            // A decoded β either fits this map's 400 cells or is refused.
            let _ = m.to_beta(Some(2), 400);
        }
    }
}
