//! Adding, listing and cancelling tasks (`rome task add | ls | cancel`):
//! plain writes and reads of the keys in [`super::schema`], so Python and
//! REST users do the same with a `set` or a `get`.

use super::schema::{
    decode, Duty, TaskSpec, TaskState, TaskStatus, CANCEL_PREFIX, STATUS_PREFIX, TASK_IDS,
    TASK_PREFIX, WAKE,
};
use rome_client::{ClientError, DataClient};
use std::collections::BTreeMap;

/// Adds a task under the next free number (`T1`, `T2` …) and wakes the
/// dispatcher; returns its id.
pub async fn add(ds: &DataClient, spec: &TaskSpec) -> Result<String, ClientError> {
    ds.create_semaphore(TASK_IDS, 0).await?;
    ds.create_semaphore(WAKE, 0).await?;
    loop {
        // Each up() answers a value no other gets: ids never clash, even
        // when many add at once. A data server started afresh counts from
        // zero again, so ids already used are passed over.
        let n = ds.signal(TASK_IDS).await?.value;
        let id = format!("T{n}");
        match ds.get(&format!("{TASK_PREFIX}{id}")).await {
            Ok(_) => continue,
            Err(e) if e.code() == Some(rome_schema::ErrorCode::UnknownVariable) => {
                add_as(ds, &id, spec).await?;
                return Ok(id);
            }
            Err(e) => return Err(e),
        }
    }
}

/// Adds a task under an id of the caller's choosing (one chunk of a key:
/// no `/`, `*`, `$` or `?`).
pub async fn add_as(ds: &DataClient, id: &str, spec: &TaskSpec) -> Result<(), ClientError> {
    check_id(id)?;
    ds.set(&format!("{TASK_PREFIX}{id}"), spec).await?;
    ds.create_semaphore(WAKE, 0).await?;
    ds.signal(WAKE).await?;
    Ok(())
}

/// Asks the dispatcher to cancel a task, with a reason for its status.
pub async fn cancel(ds: &DataClient, id: &str, why: Option<&str>) -> Result<(), ClientError> {
    check_id(id)?;
    if let Err(e) = ds.get(&format!("{TASK_PREFIX}{id}")).await {
        if e.code() == Some(rome_schema::ErrorCode::UnknownVariable) {
            return Err(ClientError::Value(format!("there is no task '{id}'")));
        }
        return Err(e);
    }
    ds.set(
        &format!("{CANCEL_PREFIX}{id}"),
        &serde_json::json!({ "why": why }),
    )
    .await?;
    ds.create_semaphore(WAKE, 0).await?;
    ds.signal(WAKE).await?;
    Ok(())
}

/// One task as `rome task ls` shows it.
#[derive(Debug, Clone, PartialEq)]
pub struct Listed {
    /// Its id.
    pub id: String,
    /// What was asked, if it decodes.
    pub spec: Result<TaskSpec, String>,
    /// What the dispatcher made of it (`None`: not seen yet, or no
    /// dispatcher runs).
    pub status: Option<TaskStatus>,
}

impl Listed {
    /// Its state, `new` when no dispatcher has seen it.
    pub fn state(&self) -> &'static str {
        match self.status.as_ref().map(|s| s.state) {
            None => "new",
            Some(TaskState::Queued) => "queued",
            Some(TaskState::Assigned) => "assigned",
            Some(TaskState::Done) => "done",
            Some(TaskState::Failed) => "failed",
            Some(TaskState::Cancelled) => "cancelled",
        }
    }
}

/// Every task, in the order of its number (`T2` before `T10`).
pub async fn list(ds: &DataClient) -> Result<Vec<Listed>, ClientError> {
    let specs = ds.values_matching(&format!("{TASK_PREFIX}*")).await?;
    let mut statuses: BTreeMap<String, TaskStatus> = BTreeMap::new();
    for (name, value) in ds.values_matching(&format!("{STATUS_PREFIX}*")).await? {
        if let (Some(id), Ok(s)) = (
            name.strip_prefix(STATUS_PREFIX),
            decode::<TaskStatus>(&name, &value),
        ) {
            statuses.insert(id.to_string(), s);
        }
    }
    let mut out: Vec<Listed> = specs
        .iter()
        .filter_map(|(name, value)| {
            let id = name.strip_prefix(TASK_PREFIX)?;
            Some(Listed {
                id: id.to_string(),
                spec: decode(name, value),
                status: statuses.remove(id),
            })
        })
        .collect();
    out.sort_by_key(|l| id_order(&l.id));
    Ok(out)
}

/// Every robot that has taken tasks, by name: its duty, or why it does
/// not decode (a `null` duty is no duty, and left out).
pub async fn robots(ds: &DataClient) -> Result<Vec<(String, Result<Duty, String>)>, ClientError> {
    let mut out = Vec::new();
    for (name, value) in ds.values_matching("nav/*/Duty").await? {
        let Some(robot) = name
            .strip_prefix("nav/")
            .and_then(|r| r.strip_suffix("/Duty"))
        else {
            continue;
        };
        if !value.is_null() {
            out.push((robot.to_string(), decode(&name, &value)));
        }
    }
    Ok(out)
}

/// Sorts `T2` before `T10`, and other ids by name after them.
fn id_order(id: &str) -> (u8, u64, String) {
    match id.strip_prefix('T').and_then(|n| n.parse().ok()) {
        Some(n) => (0, n, String::new()),
        None => (1, 0, id.to_string()),
    }
}

fn check_id(id: &str) -> Result<(), ClientError> {
    if id.is_empty() || id.contains(['/', '*', '$', '?', '#', ' ']) {
        return Err(ClientError::Value(format!(
            "'{id}' is not a task id: one word without / * $ ? # or spaces"
        )));
    }
    Ok(())
}
