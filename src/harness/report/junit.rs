//! A JUnit XML report of a run of suites, for CI systems that show test
//! results (GitLab, Jenkins, GitHub test-report actions): one `<testsuite>`
//! per suite file, one `<testcase>` per variant (classname = the suite,
//! name = `scenario::seed-k`) and per suite metric (name = the metric).
//!
//! - A variant that fails its criteria is a `<failure>` whose message is
//!   the failed criteria and whose body says what happened in both stages
//!   and where its recording (MCAP) and picture (SVG) are; the paths are
//!   repeated as `[[ATTACHMENT|path]]` lines in `<system-out>`, the form
//!   Jenkins' attachments plugin picks up.
//! - A variant that could not run is an `<error>`, and so is a metric that
//!   could not be computed because such a variant is missing.
//! - A suite file that did not load is a testsuite named after the file
//!   with one testcase, `load`, holding an `<error>` (the cargo runner's
//!   trial for such a file has the same name).
//!
//! Written by hand: the format is a dozen elements, and escaping is the
//! only subtle part. Text and attributes escape `& < > " '`; attributes
//! also keep line breaks and tabs as character references; characters
//! XML 1.0 cannot hold (control characters such as ANSI colour codes) are
//! written as `\u{..}`. Each suite and variant carries its wall time
//! (`time`, s) where the run measured it; no timestamps or host names.

use std::fmt::Write as _;

#[cfg(test)]
use super::SnapshotCheck;
use super::{RunResults, SuiteLoadFailure, SuiteRun, VariantRun};
use crate::harness::{MetricCheck, VariantOutcome};
use crate::record::markup::{escape_attribute as attr, escape_text as text};

/// The JUnit XML document of `results`.
pub fn junit_xml(results: &RunResults) -> String {
    let mut suites = String::new();
    let (mut tests, mut failures, mut errors) = (0, 0, 0);
    for failure in &results.load_failures {
        load_failure_suite(&mut suites, failure);
        tests += 1;
        errors += 1;
    }
    for run in &results.suites {
        let counts = suite(&mut suites, run);
        tests += counts.tests;
        failures += counts.failures;
        errors += counts.errors;
    }
    format!(
        "<?xml version=\"1.0\" encoding=\"UTF-8\"?>\n<testsuites name=\"safer\" tests=\"{tests}\" \
         failures=\"{failures}\" errors=\"{errors}\">\n{suites}</testsuites>\n"
    )
}

/// Test counts of one testsuite.
#[derive(Debug, Default)]
struct Counts {
    tests: usize,
    failures: usize,
    errors: usize,
}

/// What a testcase ended with.
enum Verdict {
    Passed,
    /// The test ran and did not hold: (message, body).
    Failure(String, String),
    /// The test could not run: (message, body).
    Error(String, String),
}

fn load_failure_suite(out: &mut String, failure: &SuiteLoadFailure) {
    let stem =
        failure.file.file_stem().map_or_else(|| failure.file.display().to_string(), |s| s.to_string_lossy().into());
    let file = attr(&failure.file.display().to_string());
    let _ = writeln!(
        out,
        "  <testsuite name=\"{}\" file=\"{file}\" tests=\"1\" failures=\"0\" errors=\"1\" skipped=\"0\">",
        attr(&stem)
    );
    let message = format!("suite file {} could not be loaded", failure.file.display());
    testcase(out, &stem, "load", &Verdict::Error(message, failure.message.clone()), &[], None);
    out.push_str("  </testsuite>\n");
}

fn suite(out: &mut String, run: &SuiteRun) -> Counts {
    let mut cases = String::new();
    let mut counts = Counts::default();
    let mut count = |v: &Verdict| {
        counts.tests += 1;
        match v {
            Verdict::Passed => {}
            Verdict::Failure(..) => counts.failures += 1,
            Verdict::Error(..) => counts.errors += 1,
        }
    };
    for variant in &run.variants {
        let (verdict, attachments) = variant_verdict(variant);
        count(&verdict);
        testcase(&mut cases, &run.name, variant.name_in_suite(), &verdict, &attachments, variant.wall_s);
    }
    for check in &run.checks {
        let verdict = metric_verdict(run, check);
        count(&verdict);
        testcase(&mut cases, &run.name, check.name, &verdict, &[], None);
    }
    let _ = write!(
        out,
        "  <testsuite name=\"{}\" file=\"{}\" tests=\"{}\" failures=\"{}\" errors=\"{}\" skipped=\"0\"{}>\n    \
         <properties>\n      <property name=\"planner\" value=\"{}\"/>\n",
        attr(&run.name),
        attr(&run.file.display().to_string()),
        counts.tests,
        counts.failures,
        counts.errors,
        time(run.wall_s),
        attr(&run.planner),
    );
    // Whether the conflicts reached the planner, as CI dashboards read them.
    if let Some(m) = &run.metrics {
        let rate = |v: Option<f64>| v.map_or_else(|| "-".to_string(), |x| format!("{x:.3}"));
        for (name, value) in [
            ("conflict_reach", rate(m.conflict_reach)),
            ("conflict_reach_critical", rate(m.conflict_reach_critical)),
            ("solution_rate_avoidable", rate(m.solution_rate_avoidable)),
            ("avoidable_failures", m.avoidable_failures.to_string()),
            ("no_escape_collisions", m.no_escape_collisions.to_string()),
        ] {
            let _ = writeln!(out, "      <property name=\"{name}\" value=\"{}\"/>", attr(&value));
        }
        // Conflict coverage: per kind, the variants whose conflict reached
        // the planner and its failures among them.
        for c in &m.coverage {
            let kind = c.kind.name();
            let _ = writeln!(out, "      <property name=\"conflict.{kind}\" value=\"{}\"/>", c.variants);
            let _ = writeln!(out, "      <property name=\"conflict.{kind}.failures\" value=\"{}\"/>", c.failures);
        }
    }
    // Mutation testing: the score, and per operator whether the suite
    // killed it and with how many variants.
    if let Some(m) = &run.mutation {
        let score = m.score.map_or_else(|| "-".to_string(), |x| format!("{x:.3}"));
        let _ = writeln!(out, "      <property name=\"mutation_score\" value=\"{}\"/>", attr(&score));
        for r in &m.operators {
            let verdict = if r.killed { format!("killed by {} variants", r.kills.len()) } else { "survived".into() };
            let _ =
                writeln!(out, "      <property name=\"mutant.{}\" value=\"{}\"/>", r.operator.name(), attr(&verdict));
        }
    }
    // The spec's warnings: as properties for dashboards that read them,
    // and as the suite's standard error for those that show it.
    for w in &run.warnings {
        let _ = writeln!(out, "      <property name=\"warning\" value=\"{}\"/>", attr(w));
    }
    out.push_str("    </properties>\n");
    out.push_str(&cases);
    if !run.warnings.is_empty() {
        let lines: String = run.warnings.iter().map(|w| format!("warning: {w}\n")).collect();
        let _ = writeln!(out, "    <system-err>{}</system-err>", text(&lines));
    }
    out.push_str("  </testsuite>\n");
    counts
}

/// A variant's verdict and the artefact paths to attach.
fn variant_verdict(variant: &VariantRun) -> (Verdict, Vec<String>) {
    let outcome = match &variant.outcome {
        Err(e) => return (Verdict::Error(format!("could not run the variant: {e}"), e.clone()), Vec::new()),
        Ok(o) if o.failures.is_empty() => match variant.snapshot.failure() {
            None => return (Verdict::Passed, Vec::new()),
            Some(snapshot) => return (Verdict::Failure(format!("snapshot: {snapshot}"), what_happened(o)), Vec::new()),
        },
        Ok(o) => o,
    };
    let snapshot = variant.snapshot.failure().map(|s| format!("snapshot: {s}"));
    let message = outcome
        .failures
        .iter()
        .map(|f| format!("{}: {}", f.criterion, f.what))
        .chain(snapshot.clone())
        .collect::<Vec<_>>()
        .join("; ");
    let mut body = String::new();
    for f in &outcome.failures {
        let _ = writeln!(body, "✗ {}: {}", f.criterion, f.what);
    }
    if let Some(snapshot) = &snapshot {
        let _ = writeln!(body, "✗ {snapshot}");
    }
    body.push_str(&what_happened(outcome));
    let summary = outcome.summary();
    if let Some(shrunk) = &summary.shrunk {
        let _ = writeln!(body, "shrunk: {} ({})", shrunk.describe(), shrunk.failure);
    }
    if let Some(why) = &summary.not_shrunk {
        let _ = writeln!(body, "not shrunk: {why}");
    }
    let mut attachments = Vec::new();
    match &variant.artefacts {
        Some(Ok(a)) => {
            let (mcap, svg) = (a.mcap.display().to_string(), a.svg.display().to_string());
            let stage1 = (a.stage1.0.display().to_string(), a.stage1.1.display().to_string());
            let _ = writeln!(body, "recording: {mcap}   (Foxglove, 3D panel)\npicture:   {svg}");
            let _ = writeln!(
                body,
                "stage 1:   {} and {}   ({})",
                stage1.0,
                stage1.1,
                crate::harness::artefacts::STAGE1_SHOWS
            );
            attachments = vec![mcap, svg, stage1.0, stage1.1];
            if let Some(stderr) = &a.stderr {
                let stderr = stderr.display().to_string();
                let _ = writeln!(body, "planner stderr: {stderr}");
                attachments.push(stderr);
            }
        }
        Some(Err(e)) => {
            let _ = writeln!(body, "(could not write artefacts: {e})");
        }
        None => {}
    }
    (Verdict::Failure(message, body), attachments)
}

/// Both stages of a variant in a few lines.
fn what_happened(o: &VariantOutcome) -> String {
    let s = o.summary();
    let gap = |g: Option<f64>| g.map_or_else(|| "-".into(), |g| format!("{g:.2} m"));
    let mut text = format!(
        "stage 1 (ego replays its log, CBV {}): CBV hit the ego: {}; closest gap {}\n",
        s.cbv.as_deref().unwrap_or("none"),
        if s.stage1_cbv_hit_ego { "yes" } else { "no" },
        gap(s.stage1_min_gap_m),
    );
    let _ = write!(text, "stage 2 (planner {} drives ego {}): ", s.planner, s.ego);
    match &s.stage2_collision {
        Some(c) => {
            let _ = write!(text, "ego collided with {c}");
        }
        None => text.push_str("no ego collision"),
    }
    if let Some(t) = s.stage2_off_road_s {
        let _ = write!(text, "; off the road from {t:.1} s");
    }
    if let Some(escape) = s.stage2_escape {
        let _ = write!(text, "; collision {}", escape.describe());
    }
    let _ = writeln!(
        text,
        "; closest gap to the CBV {} (conflict reached the ego: {}); closest gap {}; minimum TTC {}; ended: {}",
        gap(s.stage2_min_gap_to_cbv_m),
        if s.conflict_reached { "yes" } else { "no" },
        gap(s.stage2_min_gap_m),
        s.stage2_min_ttc_s.map_or_else(|| "-".into(), |t| format!("{t:.1} s")),
        s.stage2_termination
    );
    if let crate::harness::Stage2Verdict::Aborted { reason } = &o.verdict {
        let _ = writeln!(text, "aborted: {reason}");
    }
    text
}

fn metric_verdict(run: &SuiteRun, check: &MetricCheck) -> Verdict {
    match &check.result {
        Ok(()) => Verdict::Passed,
        // A variant it needs did not run: the metric was never measured.
        Err(why) if run.checks_unmeasured() => Verdict::Error(why.clone(), why.clone()),
        Err(why) => {
            let value = check.value.map_or_else(|| "not measured".into(), |v| format!("{v:.3}"));
            let over = run.metrics.as_ref().map_or(0, |m| m.variants);
            Verdict::Failure(
                why.clone(),
                format!("{}::{} = {value} over {over} variants\n{why}\n", run.name, check.name),
            )
        }
    }
}

/// ` time="1.234"`: a wall time in s, or nothing where none was measured.
fn time(wall_s: Option<f64>) -> String {
    wall_s.map_or_else(String::new, |t| format!(" time=\"{t:.3}\""))
}

fn testcase(
    out: &mut String,
    classname: &str,
    name: &str,
    verdict: &Verdict,
    attachments: &[String],
    wall_s: Option<f64>,
) {
    let _ = write!(out, "    <testcase classname=\"{}\" name=\"{}\"{}", attr(classname), attr(name), time(wall_s));
    let (tag, message, body) = match verdict {
        Verdict::Passed => {
            out.push_str("/>\n");
            return;
        }
        Verdict::Failure(m, b) => ("failure", m, b),
        Verdict::Error(m, b) => ("error", m, b),
    };
    let kind = if tag == "failure" { "acceptance" } else { "could-not-run" };
    let _ = writeln!(out, ">\n      <{tag} message=\"{}\" type=\"{kind}\">{}</{tag}>", attr(message), text(body));
    if !attachments.is_empty() {
        let lines: String = attachments.iter().map(|p| format!("[[ATTACHMENT|{p}]]\n")).collect();
        let _ = writeln!(out, "      <system-out>{}</system-out>", text(&lines));
    }
    out.push_str("    </testcase>\n");
}

#[cfg(test)]
mod tests {
    use super::*;
    use crate::harness::report::tests_support::{failing_variant, passing_run};
    use crate::harness::report::{RunResults, SuiteLoadFailure};

    #[test]
    fn escaping_keeps_markup_out_and_refuses_characters_xml_cannot_hold() {
        let nasty = "a<b>&\"c\" 'd'\n\te\u{1b}[31m\u{0}";
        let doc = format!("<x a=\"{}\">{}</x>", attr(nasty), text(nasty));
        let parsed = roxmltree::Document::parse(&doc).expect("well-formed");
        let root = parsed.root_element();
        assert_eq!(root.attribute("a"), Some("a<b>&\"c\" 'd'\n\te\\u{1b}[31m\\u{0}"));
        assert_eq!(root.text(), Some("a<b>&\"c\" 'd'\n\te\\u{1b}[31m\\u{0}"));
    }

    #[test]
    fn a_variant_whose_snapshot_differs_fails_as_its_test_did() {
        let mut run = passing_run();
        run.variants[0].snapshot = SnapshotCheck::Differs("snapshots/unit__crossing__seed-0.snap".into());
        assert!(!run.variants[0].passed() && !run.passed());
        let (verdict, _) = variant_verdict(&run.variants[0]);
        match verdict {
            Verdict::Failure(message, _) => assert_eq!(
                message,
                "snapshot: the summary differs from its snapshot snapshots/unit__crossing__seed-0.snap"
            ),
            _ => panic!("a snapshot difference is a failure"),
        }
        run.variants[0].snapshot = SnapshotCheck::Matches;
        assert!(matches!(variant_verdict(&run.variants[0]).0, Verdict::Passed));
    }

    #[test]
    fn a_failing_variant_an_error_and_a_load_failure_are_counted_and_described() {
        let mut run = passing_run();
        run.variants.push(failing_variant(&run.name));
        run.variants.push(VariantRun {
            name: format!("{}::broken::seed-0", run.name),
            outcome: Err("planner `x` could not be started: no such file".into()),
            artefacts: None,
            snapshot: SnapshotCheck::NotCompared,
            wall_s: None,
        });
        let results = RunResults {
            load_failures: vec![SuiteLoadFailure {
                file: "specs/suites/typo.yaml".into(),
                message: "line 5: <oops>".into(),
            }],
            suites: vec![run],
        };
        let xml = junit_xml(&results);
        let doc = roxmltree::Document::parse(&xml).expect("well-formed");
        let root = doc.root_element();
        assert_eq!(root.tag_name().name(), "testsuites");
        let cases: Vec<_> = doc.descendants().filter(|n| n.has_tag_name("testcase")).collect();
        // load + passing variant + failing + broken + one metric
        assert_eq!(cases.len(), 5, "{xml}");
        assert_eq!(root.attribute("tests"), Some("5"));
        assert_eq!(root.attribute("failures"), Some("1"));
        assert_eq!(root.attribute("errors"), Some("2"));
        let failure = doc.descendants().find(|n| n.has_tag_name("failure")).expect("a failure");
        let case = failure.parent().unwrap();
        assert_eq!(case.attribute("classname"), Some("unit"));
        assert_eq!(case.attribute("name"), Some("crossing::seed-1"));
        assert!(failure.attribute("message").unwrap().starts_with("no_collision: "), "{xml}");
        let body = failure.text().unwrap();
        assert!(body.contains("recording: out/unit/crossing/seed-1.mcap"), "{body}");
        assert!(body.contains("stage 1:   out/unit/crossing/seed-1.stage1.mcap and"), "{body}");
        assert!(xml.contains("[[ATTACHMENT|out/unit/crossing/seed-1.stage1.svg]]"), "{xml}");
        assert!(body.contains("stage 2 (planner"), "{body}");
        // Wall times where the run measured them, none where it did not.
        let suite = doc.descendants().find(|n| n.has_tag_name("testsuite") && n.attribute("name") == Some("unit"));
        assert_eq!(suite.unwrap().attribute("time"), Some("1.500"), "{xml}");
        assert_eq!(case.attribute("time"), Some("2.500"), "{xml}");
        let broken = cases.iter().find(|c| c.attribute("name") == Some("broken::seed-0")).unwrap();
        assert_eq!(broken.attribute("time"), None, "{xml}");
        let load = cases.iter().find(|c| c.attribute("name") == Some("load")).unwrap();
        assert_eq!(load.attribute("classname"), Some("typo"));
        assert!(load.children().any(|n| n.has_tag_name("error") && n.text() == Some("line 5: <oops>")));
    }

    #[test]
    fn the_spec_warnings_are_properties_and_the_suites_stderr_and_leave_the_verdict() {
        let quiet = junit_xml(&RunResults { load_failures: Vec::new(), suites: vec![passing_run()] });
        assert!(!quiet.contains("warning") && !quiet.contains("system-err"), "{quiet}");
        let mut run = passing_run();
        run.warnings = vec!["s.yaml:3:1: no `adversary.method` <log>".into(), "s.yaml:9:3: second".into()];
        let xml = junit_xml(&RunResults { load_failures: Vec::new(), suites: vec![run] });
        let doc = roxmltree::Document::parse(&xml).expect("well-formed");
        let warnings: Vec<_> = doc
            .descendants()
            .filter(|n| n.has_tag_name("property") && n.attribute("name") == Some("warning"))
            .filter_map(|n| n.attribute("value"))
            .collect();
        assert_eq!(warnings, ["s.yaml:3:1: no `adversary.method` <log>", "s.yaml:9:3: second"], "{xml}");
        let suite = doc.descendants().find(|n| n.has_tag_name("testsuite")).unwrap();
        let stderr = suite.children().find(|n| n.has_tag_name("system-err")).expect("the suite's stderr");
        assert_eq!(
            stderr.text(),
            Some("warning: s.yaml:3:1: no `adversary.method` <log>\nwarning: s.yaml:9:3: second\n")
        );
        // The schema's order: properties, test cases, then system-err.
        assert_eq!(suite.children().rfind(|n| n.is_element()), Some(stderr), "{xml}");
        assert_eq!((suite.attribute("failures"), suite.attribute("errors")), (Some("0"), Some("0")), "{xml}");
    }
}
