//! Ego and CBV assignment. Being written.

use super::Scenario;

/// Fills in ego and CBV where the source named none.
pub fn assign(_scenario: &mut Scenario) {}
