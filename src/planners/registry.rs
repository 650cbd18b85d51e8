//! In-process planners registered by name: a planner crate's test target
//! registers its own [`Planner`] implementation (usually through
//! `safer_scenarios::runner::Runner::planner`), and a suite names it with
//! `planner: { rust: NAME }`. The registry is process-wide because suites are
//! loaded and variants run on any worker thread.

use std::collections::BTreeMap;
use std::sync::{Arc, OnceLock, RwLock};

use super::Planner;
use crate::scenario::{Scenario, TrackIndex};

/// Makes a fresh planner for the ego `TrackIndex` of a scenario, once per
/// variant (a planner keeps state between steps, never between variants).
pub type PlannerFactory = Arc<dyn Fn(&Scenario, TrackIndex) -> Box<dyn Planner> + Send + Sync>;

/// Why a planner could not be registered.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
pub enum RegistryError {
    /// Names appear in test names and suite files: they must be plain.
    #[error("planner name `{0}` is not valid: use letters, digits, `-`, `_` and `.` only")]
    InvalidName(String),
    /// Two planners under one name would make a suite ambiguous.
    #[error("a planner named `{0}` is already registered")]
    Duplicate(String),
}

fn registry() -> &'static RwLock<BTreeMap<String, PlannerFactory>> {
    static REGISTRY: OnceLock<RwLock<BTreeMap<String, PlannerFactory>>> = OnceLock::new();
    REGISTRY.get_or_init(Default::default)
}

/// Registers `factory` under `name`.
pub fn register(name: &str, factory: PlannerFactory) -> Result<(), RegistryError> {
    let plain = !name.is_empty() && name.chars().all(|c| c.is_ascii_alphanumeric() || matches!(c, '-' | '_' | '.'));
    if !plain {
        return Err(RegistryError::InvalidName(name.into()));
    }
    let mut planners = registry().write().unwrap_or_else(|p| p.into_inner());
    if planners.contains_key(name) {
        return Err(RegistryError::Duplicate(name.into()));
    }
    planners.insert(name.into(), factory);
    Ok(())
}

/// The factory registered under `name`.
pub fn lookup(name: &str) -> Option<PlannerFactory> {
    registry().read().unwrap_or_else(|p| p.into_inner()).get(name).cloned()
}

/// The registered names, sorted.
pub fn registered_names() -> Vec<String> {
    registry().read().unwrap_or_else(|p| p.into_inner()).keys().cloned().collect()
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::planners::ConstantVelocityPlanner;

    fn factory() -> PlannerFactory {
        Arc::new(|_: &Scenario, _: TrackIndex| Box::new(ConstantVelocityPlanner) as Box<dyn Planner>)
    }

    #[test]
    fn a_registered_planner_is_found_and_a_second_one_under_its_name_is_refused() {
        register("registry-test-cv", factory()).unwrap();
        assert!(lookup("registry-test-cv").is_some());
        assert!(registered_names().contains(&"registry-test-cv".to_string()));
        assert_eq!(
            register("registry-test-cv", factory()).unwrap_err(),
            RegistryError::Duplicate("registry-test-cv".into())
        );
        assert!(lookup("registry-test-unknown").is_none());
    }

    #[test]
    fn names_that_cannot_be_test_names_are_refused() {
        for bad in ["", "my planner", "a::b", "x/y"] {
            assert_eq!(register(bad, factory()).unwrap_err(), RegistryError::InvalidName(bad.into()));
        }
    }
}
