//! A planner that panics in `plan` must fail its variant like a planner
//! process that crashes: at the step, with its message, its recording and
//! its picture, and the other variants going on. [`PanicGuard`] wraps an
//! in-process planner and turns a panic into [`PlannerError::Panicked`].

use std::panic::{AssertUnwindSafe, catch_unwind};

use super::{Observation, Planner, PlannerError, PlannerOutput, PlannerStartup};

/// Most characters of a panic message kept.
const MESSAGE_CHARS: usize = 2000;

/// `inner`, with a panic in any of its calls turned into an error.
pub struct PanicGuard {
    inner: Box<dyn Planner>,
    /// Set once it panicked: its state may be broken, so it is not called again.
    panicked: Option<String>,
}

impl PanicGuard {
    /// Guards `inner`.
    pub fn new(inner: Box<dyn Planner>) -> Self {
        Self { inner, panicked: None }
    }
}

/// The text of a panic's payload (`panic!("…")` gives a `&str` or a `String`).
pub fn panic_message(payload: &(dyn std::any::Any + Send)) -> String {
    let text = payload
        .downcast_ref::<&str>()
        .map(|s| s.to_string())
        .or_else(|| payload.downcast_ref::<String>().cloned())
        .unwrap_or_else(|| "a panic without a message".to_string());
    crate::message_text::cut_with_length(&text, MESSAGE_CHARS)
}

impl Planner for PanicGuard {
    fn name(&self) -> &str {
        self.inner.name()
    }

    fn plan(&mut self, observation: &Observation<'_>) -> Result<PlannerOutput, PlannerError> {
        let planner = self.inner.name().to_string();
        if let Some(message) = &self.panicked {
            return Err(PlannerError::Panicked { planner, message: message.clone() });
        }
        match catch_unwind(AssertUnwindSafe(|| self.inner.plan(observation))) {
            Ok(result) => result,
            Err(payload) => {
                let message = panic_message(payload.as_ref());
                self.panicked = Some(message.clone());
                Err(PlannerError::Panicked { planner, message })
            }
        }
    }

    fn end_rollout(&mut self) -> Option<String> {
        if self.panicked.is_some() {
            return None;
        }
        catch_unwind(AssertUnwindSafe(|| self.inner.end_rollout())).unwrap_or(None)
    }

    fn take_debug(&mut self) -> Option<serde_json::Value> {
        if self.panicked.is_some() {
            return None;
        }
        catch_unwind(AssertUnwindSafe(|| self.inner.take_debug())).unwrap_or(None)
    }

    fn startup(&self) -> Option<PlannerStartup> {
        self.inner.startup()
    }
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::sim::{SimConfig, Simulation, Termination};

    struct Boom(usize);

    impl Planner for Boom {
        fn name(&self) -> &str {
            "boom"
        }
        fn plan(&mut self, _: &Observation<'_>) -> Result<PlannerOutput, PlannerError> {
            if self.0 == 0 {
                panic!("boom");
            }
            self.0 -= 1;
            Ok(PlannerOutput::Control(crate::motion::Action::default()))
        }
    }

    #[test]
    fn a_panic_in_plan_fails_the_rollout_at_its_step_with_the_message() {
        let s = crate::record::test_support::crossing_scenario();
        let mut guarded = PanicGuard::new(Box::new(Boom(3)));
        let rollout = Simulation::new(&s, SimConfig::default()).unwrap().run(&mut guarded);
        match &rollout.termination {
            Termination::PlannerFailed { step, reason } => {
                assert_eq!(*step, s.current_step + 3);
                assert_eq!(reason, "planner `boom` panicked: boom");
            }
            other => panic!("{other:?}"),
        }
        assert_eq!(rollout.states.len(), 4, "the steps before the panic are kept");
    }

    #[test]
    fn a_panic_message_is_cut() {
        let long = "x".repeat(10_000);
        let message = panic_message(&long);
        assert!(message.ends_with("(10000 characters in all)") && message.len() < 2100, "{message}");
    }
}
