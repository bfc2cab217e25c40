//! Where the time goes: one [`Timings`] for every stage that measures itself — `make`'s stages
//! (report.json's `timings_ms`, the CLI's per-stage lines), the phases of the bridge stage (its
//! benchmark) and the steps of the mesh renderer (its benchmark). A leaf module: it knows no
//! stage, so any of them may use it.

use std::collections::BTreeMap;
use std::sync::Arc;
use std::time::Instant;

/// Told the name of each stage of `make` as it starts: the keys of the report's `timings_ms`
/// ("tone", "filter", "islands", "bridge", ...), then "write" (encoding and writing the files).
/// The CLI draws a progress bar from it; the library draws nothing.
pub trait Progress: Send + Sync {
    /// Told as the stage `name` starts.
    fn stage(&self, name: &str);
}

impl std::fmt::Debug for dyn Progress {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.write_str("Progress")
    }
}

/// Wall-clock milliseconds per named stage, in name order (how report.json lists them); a stage
/// that runs more than once, such as the trace and check after each neck repair, adds up. Who
/// to tell when a stage starts, if anyone.
#[derive(Clone, Debug, Default)]
pub struct Timings {
    ms: BTreeMap<String, f64>,
    progress: Option<Arc<dyn Progress>>,
}

impl Timings {
    /// Timings that tell `progress` (when given) each stage as it starts.
    pub fn new(progress: Option<Arc<dyn Progress>>) -> Timings {
        Timings {
            ms: BTreeMap::new(),
            progress,
        }
    }

    /// Run `f` as the stage `name`, adding its wall-clock time to the stage's.
    pub(crate) fn time<T>(&mut self, name: &str, f: impl FnOnce() -> T) -> T {
        if let Some(p) = &self.progress {
            p.stage(name);
        }
        let t = Instant::now();
        let r = f();
        self.add(name, t.elapsed().as_secs_f64() * 1e3);
        r
    }

    /// Add `ms` milliseconds to the stage `name`.
    pub fn add(&mut self, name: &str, ms: f64) {
        *self.ms.entry(name.to_string()).or_default() += ms;
    }

    /// Milliseconds spent in the stage `name` (0 if it never ran).
    pub fn get(&self, name: &str) -> f64 {
        self.ms.get(name).copied().unwrap_or(0.0)
    }

    /// Every stage and its milliseconds, in name order.
    pub fn iter(&self) -> impl Iterator<Item = (&str, f64)> {
        self.ms.iter().map(|(k, &v)| (k.as_str(), v))
    }

    /// The stages' milliseconds keyed by name, as report.json holds them.
    pub(crate) fn into_map(self) -> BTreeMap<String, f64> {
        self.ms
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use std::sync::Mutex;

    #[derive(Default)]
    struct Told(Mutex<Vec<String>>);
    impl Progress for Told {
        fn stage(&self, name: &str) {
            self.0.lock().unwrap().push(name.to_string());
        }
    }

    /// Stages add up by name, come out in name order, and each is told as it starts.
    #[test]
    fn stages_add_up_by_name_and_are_told() {
        let told = Arc::new(Told::default());
        let mut t = Timings::new(Some(told.clone()));
        assert_eq!(t.time("vector", || 7), 7);
        t.add("check", 2.0);
        t.add("check", 3.5);
        t.time("check", || ());
        assert!(t.get("check") >= 5.5);
        assert_eq!(t.get("never"), 0.0);
        let names: Vec<&str> = t.iter().map(|(k, _)| k).collect();
        assert_eq!(names, ["check", "vector"]);
        assert_eq!(*told.0.lock().unwrap(), ["vector", "check"]);
        assert_eq!(t.into_map().len(), 2);
    }
}
