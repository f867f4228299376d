//! Tasks for a fleet (§4.7: several robots, one data server): errands kept
//! on the data server, a dispatcher that hands each to a free robot, and
//! a robot's Planner that takes them.
//!
//! How this module is laid out:
//! - [`schema`]: the keys and values, one writer each (docs/keys.md).
//! - [`tasks`]: adding, listing and cancelling (`rome task`).
//! - [`assign`]: which free robot takes which task (shortest route).
//! - [`dispatcher`]: the one dispatcher's rounds (`rome dispatcher`).
//! - [`duty`]: a robot taking tasks (`rome planner --tasks`).
//! - `carry`: one task planned, driven and judged.
//! - `watch`: what ends a task's run early (cancelled, blocked, overdue).
//! - [`way`]: a robot held up asks the nearest idle robot in its way to make way.
//! - [`aside`]: where a robot without a task waits.
//! - [`clear`]: where a robot out of service drives to get clear.

pub mod aside;
pub mod assign;
mod carry;
pub mod clear;
pub mod dispatcher;
pub mod duty;
pub mod schema;
pub mod tasks;
mod watch;
pub mod way;
