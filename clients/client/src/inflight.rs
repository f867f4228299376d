//! Subscriptions the lock-step clock counts arrivals on: a message one
//! participant publishes to another keeps simulated time still until it
//! has crossed the network (see `rome_clock::subscribed`).

use zenoh::handlers::{Callback, IntoHandler};
use zenoh::key_expr::{keyexpr, OwnedKeyExpr};
use zenoh::sample::Sample;

/// `channel` as a subscription on `key` declares it, telling the clock of
/// every arrival when the subscriber is a lock-step participant.
pub(crate) fn counted<C: IntoHandler<Sample>>(
    key: &str,
    channel: C,
) -> (Callback<Sample>, C::Handler) {
    let (callback, handler) = channel.into_handler();
    let inbound = OwnedKeyExpr::new(key).ok().and_then(|ke| {
        rome_clock::subscribed(move |k| keyexpr::new(k).is_ok_and(|k| ke.intersects(k)))
    });
    match inbound {
        None => (callback, handler),
        Some(inbound) => (
            Callback::from(move |s: Sample| {
                callback.call(s);
                inbound.received();
            }),
            handler,
        ),
    }
}
