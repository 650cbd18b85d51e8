//! In-process planners registered by name: a planner crate's test target
//! registers its own [`Planner`] implementation (through
//! `safer_scenarios::runner::Runner::planner`), and a suite names it with
//! `planner: { rust: NAME }`. The runner holds the registry; a suite
//! resolves the name when it is loaded.

use std::collections::BTreeMap;
use std::sync::Arc;

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

/// In-process planners by name. A [`crate::runner::Runner`] holds one and
/// hands it to the suites it loads, which resolve `planner: { rust: NAME }`
/// to its factory at load time: no process-wide state, so two runners in
/// one process (or a test and its harness) never see each other's planners.
#[derive(Clone, Default)]
pub struct PlannerRegistry {
    planners: BTreeMap<String, PlannerFactory>,
}

impl std::fmt::Debug for PlannerRegistry {
    fn fmt(&self, f: &mut std::fmt::Formatter<'_>) -> std::fmt::Result {
        f.debug_struct("PlannerRegistry").field("names", &self.names()).finish()
    }
}

impl PlannerRegistry {
    /// Registers `factory` under `name`.
    pub fn register(&mut self, name: &str, factory: PlannerFactory) -> Result<(), RegistryError> {
        let plain = !name.is_empty() && name.chars().all(|c| c.is_ascii_alphanumeric() || matches!(c, '-' | '_' | '.'));
        if !plain {
            return Err(RegistryError::InvalidName(name.into()));
        }
        if self.planners.contains_key(name) {
            return Err(RegistryError::Duplicate(name.into()));
        }
        self.planners.insert(name.into(), factory);
        Ok(())
    }

    /// [`PlannerRegistry::register`], for building one in an expression.
    pub fn with(mut self, name: &str, factory: PlannerFactory) -> Result<Self, RegistryError> {
        self.register(name, factory)?;
        Ok(self)
    }

    /// The factory registered under `name`.
    pub fn lookup(&self, name: &str) -> Option<PlannerFactory> {
        self.planners.get(name).cloned()
    }

    /// The registered names, sorted.
    pub fn names(&self) -> Vec<String> {
        self.planners.keys().cloned().collect()
    }
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
        let mut registry = PlannerRegistry::default();
        registry.register("registry-test-cv", factory()).unwrap();
        assert!(registry.lookup("registry-test-cv").is_some());
        assert_eq!(registry.names(), ["registry-test-cv"]);
        assert_eq!(
            registry.register("registry-test-cv", factory()).unwrap_err(),
            RegistryError::Duplicate("registry-test-cv".into())
        );
        assert!(registry.lookup("registry-test-unknown").is_none());
        // Another registry knows nothing of this one's planners.
        assert!(PlannerRegistry::default().lookup("registry-test-cv").is_none());
    }

    #[test]
    fn names_that_cannot_be_test_names_are_refused() {
        for bad in ["", "my planner", "a::b", "x/y"] {
            assert_eq!(
                PlannerRegistry::default().register(bad, factory()).unwrap_err(),
                RegistryError::InvalidName(bad.into())
            );
        }
    }
}
