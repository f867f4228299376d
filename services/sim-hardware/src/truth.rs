//! The simulator's ground truth on Zenoh (`<root>/sim/<robot>/truth`):
//! each robot's true pose and contacts, answered to queries (wildcards
//! too: `rome/sim/*/truth` gets one reply per robot) and published as a
//! stream. It belongs to the world, not to any robot's hardware servers,
//! and navigation never reads it.

use crate::world::SimWorld;
use rome_hardware::server::{declare_err, ServerError};
use rome_maps::plane::Plane;
use rome_schema::robot::robot_name;
use rome_schema::sim::{ContactCount, Truth};
use rome_schema::{encode, Root};
use rome_serve::{Event, Handler, Inbox, Periods};
use std::future::Future;
use std::time::Duration;
use zenoh::bytes::Encoding;
use zenoh::key_expr::KeyExpr;
use zenoh::qos::CongestionControl;
use zenoh::Session;

/// How many queries may wait before new ones are answered `busy`.
const QUERY_QUEUE: usize = 1024;

/// A robot's truth; in a building's world, on its floor's map.
fn truth(r: &rome_sim::Robot, time_ms: u64, plane: Option<&Plane>) -> Truth {
    let c = r.contacts;
    let contacts = ContactCount {
        wall: c.wall,
        robot: c.robot,
        bumper: c.bumper,
    };
    let mut pose = r.pose;
    let floor = plane.and_then(|p| p.local(r.pose.at)).map(|(floor, at)| {
        pose.at = at;
        floor.to_string()
    });
    Truth {
        floor,
        ..rome_maps::wire::truth(&r.name, time_ms, &pose, r.travelled_mm, contacts)
    }
}

/// Robot `i`'s truth now.
pub fn truth_of(world: &SimWorld, i: usize) -> Truth {
    let sim = world.lock();
    truth(sim.robot(i), sim.time_ms(), world.plane())
}

/// Every robot's truth now, with its key.
pub fn snapshot(world: &SimWorld, root: &Root) -> Vec<(String, Truth)> {
    let sim = world.lock();
    let time_ms = sim.time_ms();
    sim.robots()
        .iter()
        .filter_map(|r| {
            // A robot whose name is no key chunk has no truth key.
            let key = root.sim_truth(&robot_name(&r.name).ok()?);
            Some((key, truth(r, time_ms, world.plane())))
        })
        .collect()
}

/// Serves and publishes the truth of every robot in `world` until
/// `shutdown` resolves; `period` is the stream's (`None`: queries only).
pub async fn run(
    session: Session,
    root: Root,
    world: SimWorld,
    period: Option<Duration>,
    shutdown: impl Future<Output = ()>,
) -> Result<(), ServerError> {
    let inbox = Inbox::new("the truth server", QUERY_QUEUE);
    let _queryable = session
        .declare_queryable(root.sim_truth_all())
        .callback(inbox.on_query())
        .await
        .map_err(|e| declare_err("the truth queryable", e))?;
    let _token = rome_serve::presence::declare(&session, &root.alive_server("sim", "truth"))
        .await
        .map_err(|e| declare_err("the liveliness token", e))?;
    let mut server = TruthServer {
        keys: rome_serve::keys::Declared::new(&session),
        session,
        root,
        world,
    };
    let periods = Periods {
        sweep: Duration::from_secs(3_600),
        tick: period,
    };
    inbox.run(&mut server, periods, shutdown).await;
    Ok(())
}

struct TruthServer {
    session: Session,
    /// Each robot's truth key, declared once (see `rome_serve::keys`).
    keys: rome_serve::keys::Declared,
    root: Root,
    world: SimWorld,
}

impl Handler<std::convert::Infallible> for TruthServer {
    async fn event(&mut self, event: Event<std::convert::Infallible>) {
        let Event::Query(query) = event else { return };
        for (key, truth) in snapshot(&self.world, &self.root) {
            let Ok(k) = KeyExpr::try_from(key.as_str()) else {
                continue;
            };
            if query.key_expr().intersects(&k) {
                rome_serve::reply(&query, &key, encode(&truth), Encoding::APPLICATION_JSON).await;
            }
        }
    }

    async fn sweep(&mut self) {}

    async fn tick(&mut self) {
        for (key, truth) in snapshot(&self.world, &self.root) {
            let Some(key) = self.keys.get(&key) else {
                continue;
            };
            let _ = self
                .session
                .put(key, encode(&truth))
                .encoding(Encoding::APPLICATION_JSON)
                .congestion_control(CongestionControl::Drop)
                .await;
        }
    }
}
