//! A static review page of a run of suites: one `index.html` that opens
//! from the file system with no network (no external script, style sheet
//! or font), and the pictures of the failing variants beside it under
//! `pictures/suite/scenario/seed-k.svg`.
//!
//! The page shows every suite with its verdict, a table of its variants
//! (verdict, stage-1 and stage-2 key figures, the failed criteria), its
//! suite metrics and their checks; suite files that did not load, with
//! their message; and for each failing variant what happened, its
//! picture, a link to its MCAP recording (relative to the page, for
//! Foxglove) and an animated top-down view of the stage-2 rollout (the
//! ego, the CBV and the other agents as oriented boxes over the road,
//! [`RolloutAnimation`]) with a step slider and a play button. The
//! animation's data is embedded as JSON and drawn by a small inline script.
//!
//! All text from specs, logs and planners is escaped; JSON inside the page
//! has every `<`, `>` and `&` written as `\u003c`, `\u003e`, `\u0026`, so
//! no string can close its script element. The markup is also well-formed
//! XML (void elements closed, scripts in commented CDATA sections), so
//! tests and tools can read it with an XML parser. The page has no timestamp: the same results give the same
//! bytes. The folder must be missing, empty, or hold an earlier review
//! page ([`check_folder`]): the page never writes into a folder of the
//! user's other files.

use std::fmt::Write as _;
use std::path::{Component, Path, PathBuf};

use super::{RunResults, SuiteRun, VariantRun};
use crate::harness::artefacts::WitnessArtefact;
use crate::harness::{Stage2Verdict, VariantOutcome};
use crate::record::animation::RolloutAnimation;
use crate::record::markup::escape_attribute as esc;
use crate::record::{self, RecordError, SvgOptions};

/// The page's file name in its folder.
pub const PAGE_FILE: &str = "index.html";
/// Marks a page this module wrote, so a later run may replace it.
const GENERATOR: &str = "safer review page";

/// Checks, before a run, that `dir` can take a review page: it does not
/// exist yet, is empty, or holds an earlier review page.
pub fn check_folder(dir: &Path) -> Result<(), RecordError> {
    let refuse = |reason: String| RecordError::InvalidPath { path: dir.to_path_buf(), reason };
    if crate::record::is_stdout(dir) {
        return Err(refuse("the review page is a folder (index.html and pictures), not standard output".into()));
    }
    let entries = match std::fs::read_dir(dir) {
        Ok(entries) => entries,
        Err(e) if e.kind() == std::io::ErrorKind::NotFound => return Ok(()),
        Err(_) if dir.exists() && !dir.is_dir() => {
            return Err(refuse("it is not a folder (the review page is a folder: index.html and pictures)".into()));
        }
        Err(source) => return Err(RecordError::Io { path: dir.to_path_buf(), source }),
    };
    if entries.count() == 0 {
        return Ok(());
    }
    let page = dir.join(PAGE_FILE);
    let ours = std::fs::read_to_string(&page).is_ok_and(|t| t.contains(GENERATOR));
    if ours {
        Ok(())
    } else {
        Err(refuse(format!(
            "the folder holds other files and no earlier review page ({} written by safer); \
             choose a new or empty folder",
            page.display()
        )))
    }
}

/// Writes the review page of `results` into `dir` (created if missing; see
/// [`check_folder`]) and the pictures of failing variants beside it;
/// returns the page's path. Links to recordings are relative to `dir`.
pub fn write_review_page(dir: &Path, results: &RunResults) -> Result<PathBuf, RecordError> {
    check_folder(dir)?;
    std::fs::create_dir_all(dir).map_err(|source| RecordError::Io { path: dir.to_path_buf(), source })?;
    let mut pictures = Vec::new();
    let html = page_html(results, dir, &mut pictures);
    for (path, svg) in pictures {
        record::create_parent_folder(&path)?;
        record::write_svg(&path, &svg)?;
    }
    let page = dir.join(PAGE_FILE);
    record::write_output(&page, html.as_bytes())?;
    Ok(page)
}

/// A relative path as a URL path: every byte but unreserved ones and `/` percent-encoded.
fn url_path(path: &Path) -> String {
    let parts: Vec<String> = path.components().map(|c| c.as_os_str().to_string_lossy().into_owned()).collect();
    let mut out = String::new();
    for (i, part) in parts.iter().enumerate() {
        if i > 0 {
            out.push('/');
        }
        for b in part.bytes() {
            if b.is_ascii_alphanumeric() || b"-._~".contains(&b) {
                out.push(b as char);
            } else {
                let _ = write!(out, "%{b:02X}");
            }
        }
    }
    out
}

/// `path` made absolute and `..` resolved by name (without touching the file system).
fn lexical_absolute(path: &Path) -> PathBuf {
    let abs = std::path::absolute(path).unwrap_or_else(|_| path.to_path_buf());
    let mut out = PathBuf::new();
    for c in abs.components() {
        match c {
            Component::ParentDir => {
                out.pop();
            }
            Component::CurDir => {}
            c => out.push(c),
        }
    }
    out
}

/// `target` relative to the folder `base`.
fn relative_to(base: &Path, target: &Path) -> PathBuf {
    let (base, target) = (lexical_absolute(base), lexical_absolute(target));
    let (b, t): (Vec<_>, Vec<_>) = (base.components().collect(), target.components().collect());
    let common = b.iter().zip(&t).take_while(|(x, y)| x == y).count();
    if common == 0 {
        // Nothing shared (another drive): only an absolute path names it.
        return target;
    }
    let mut rel = PathBuf::new();
    for _ in common..b.len() {
        rel.push("..");
    }
    for c in &t[common..] {
        rel.push(c);
    }
    rel
}

fn count(n: usize, what: &str) -> String {
    format!("{n} {what}{}", if n == 1 { "" } else { "s" })
}

fn opt(v: Option<f64>, decimals: usize) -> String {
    v.map_or_else(|| "–".to_string(), |x| format!("{x:.decimals$}"))
}

/// Stage 2 in a few words.
fn stage2_text(o: &VariantOutcome) -> String {
    match &o.verdict {
        Stage2Verdict::Solved => "solved".into(),
        Stage2Verdict::Collided { .. } => {
            let s = o.stage2.summary();
            match s.ego_collision {
                Some(c) => format!(
                    "collided with {} at {:.1} s ({}at fault)",
                    c.other,
                    c.time_s,
                    if c.at_fault { "" } else { "not " }
                ),
                None => "collided".into(),
            }
        }
        Stage2Verdict::Aborted { reason } => format!("aborted: {reason}"),
    }
}

/// The page; pictures to write are pushed to `pictures` (path, SVG).
fn page_html(results: &RunResults, dir: &Path, pictures: &mut Vec<(PathBuf, String)>) -> String {
    let (mut variants, mut failed, mut checks, mut checks_failed) = (0, 0, 0, 0);
    for s in &results.suites {
        variants += s.variants.len();
        failed += s.variants.iter().filter(|v| !v.passed()).count();
        checks += s.checks.len();
        checks_failed += s.checks.iter().filter(|c| c.result.is_err()).count();
    }
    let verdict = if results.passed() { "PASS" } else { "FAIL" };
    let mut summary = format!(
        "{verdict}: {}, {failed} failed; {}, {checks_failed} failed",
        count(variants, "variant"),
        count(checks, "metric check")
    );
    if !results.load_failures.is_empty() {
        let _ = write!(summary, "; {} could not be loaded", count(results.load_failures.len(), "suite file"));
    }

    let mut h = String::with_capacity(64 * 1024);
    let _ = write!(
        h,
        "<!DOCTYPE html>\n<html lang=\"en\">\n<head>\n<meta charset=\"utf-8\"/>\n\
         <meta name=\"generator\" content=\"{GENERATOR}\"/>\n\
         <meta name=\"viewport\" content=\"width=device-width, initial-scale=1\"/>\n\
         <title>safer review: {}</title>\n<style>{STYLE}</style>\n</head>\n<body>\n<header>\n<h1>safer review</h1>\n\
         <p class=\"summary {}\">{}</p>\n",
        esc(&summary),
        verdict.to_lowercase(),
        esc(&summary)
    );
    if results.suites.len() + results.load_failures.len() > 1 {
        h.push_str("<nav>");
        for (si, s) in results.suites.iter().enumerate() {
            let class = if s.passed() { "pass" } else { "fail" };
            let _ = write!(h, "<a class=\"{class}\" href=\"#suite-{si}\">{}</a> ", esc(&s.name));
        }
        if !results.load_failures.is_empty() {
            h.push_str("<a class=\"fail\" href=\"#load-failures\">not loaded</a>");
        }
        h.push_str("</nav>\n");
    }
    h.push_str("</header>\n<main>\n");
    if !results.load_failures.is_empty() {
        h.push_str("<section id=\"load-failures\">\n<h2>Suite files that could not be loaded</h2>\n");
        for f in &results.load_failures {
            let _ = writeln!(
                h,
                "<div class=\"load-failure\"><h3>{}</h3><pre>{}</pre></div>",
                esc(&f.file.display().to_string()),
                esc(&f.message)
            );
        }
        h.push_str("</section>\n");
    }
    for (si, s) in results.suites.iter().enumerate() {
        suite_html(&mut h, si, s, dir, pictures);
    }
    let _ = write!(
        h,
        "</main>\n<pre id=\"js-errors\" hidden=\"hidden\"></pre>\n<script>//<![CDATA[\n{ERROR_SCRIPT}\n//]]></script>\n<script>//<![CDATA[{PLAYER_SCRIPT}//]]></script>\n\
         </body>\n</html>\n"
    );
    h
}

fn suite_html(h: &mut String, si: usize, s: &SuiteRun, dir: &Path, pictures: &mut Vec<(PathBuf, String)>) {
    let (class, verdict) = if s.passed() { ("pass", "PASS") } else { ("fail", "FAIL") };
    let _ = write!(
        h,
        "<section class=\"suite\" id=\"suite-{si}\">\n<h2>suite {} <span class=\"badge {class}\">{verdict}</span></h2>\n\
         <p class=\"meta\">{} · planner <b>{}</b> · {}</p>\n",
        esc(&s.name),
        esc(&s.file.display().to_string()),
        esc(&s.planner),
        count(s.variants.len(), "variant")
    );
    for w in &s.warnings {
        let _ = writeln!(h, "<p class=\"spec-warning\">warning: {}</p>", esc(w));
    }
    if !s.variants.is_empty() {
        h.push_str(
            "<table class=\"variants\">\n<thead><tr><th>variant</th><th>verdict</th><th>stage 1: CBV hit ego</th>\
             <th>stage 1: min gap m</th><th>stage 2</th><th>min gap m</th><th>min TTC s</th><th>off road from s</th>\
             </tr></thead>\n<tbody>\n",
        );
        for (vi, v) in s.variants.iter().enumerate() {
            variant_row(h, si, vi, v);
        }
        h.push_str("</tbody>\n</table>\n");
    }
    if let Some(m) = &s.metrics {
        let _ = writeln!(h, "<p class=\"metrics-line\">{}</p>", esc(&m.headline(" · ")));
        let coverage = m.coverage_table();
        if !coverage.is_empty() {
            let _ = writeln!(h, "<pre class=\"coverage\">{}</pre>", esc(&coverage.join("\n")));
        }
    }
    if !s.checks.is_empty() {
        h.push_str("<table class=\"checks\">\n<thead><tr><th>suite metric</th><th>value</th><th>check</th></tr></thead>\n<tbody>\n");
        for c in &s.checks {
            let result = match &c.result {
                Ok(()) => "<span class=\"badge pass\">PASS</span>".to_string(),
                Err(why) => format!("<span class=\"badge fail\">FAIL</span> {}", esc(why)),
            };
            let _ = writeln!(
                h,
                "<tr><td>{}::{}</td><td class=\"num\">{}</td><td>{result}</td></tr>",
                esc(&s.name),
                esc(c.name),
                opt(c.value, 3)
            );
        }
        h.push_str("</tbody>\n</table>\n");
    }
    if let Some(m) = &s.mutation {
        mutation_html(h, m);
    }
    for (vi, v) in s.variants.iter().enumerate() {
        if let Ok(o) = &v.outcome
            && !o.failures.is_empty()
        {
            failing_variant_html(h, si, vi, v, o, dir, pictures);
        }
    }
    h.push_str("</section>\n");
}

/// The suite's mutation run: the score, then per operator killed (by how
/// many variants, the first and how) or survived (with the hint).
fn mutation_html(h: &mut String, m: &crate::harness::mutation::MutationReport) {
    let _ = writeln!(h, "<p class=\"metrics-line\">{}</p>", esc(&m.headline()));
    h.push_str("<table class=\"checks mutation\">\n<thead><tr><th>mutant</th><th>fault</th><th>verdict</th></tr></thead>\n<tbody>\n");
    for r in &m.operators {
        let verdict = match r.kills.first() {
            Some(k) => format!(
                "<span class=\"badge pass\">KILLED</span> by {} of {} variants; first {}: {}: {}",
                r.kills.len(),
                m.variants_passed,
                esc(&k.variant),
                esc(&k.criterion),
                esc(&k.what)
            ),
            None => format!("<span class=\"badge fail\">SURVIVED</span> {}", esc(&r.survivor_note())),
        };
        let _ = writeln!(
            h,
            "<tr><td>{}</td><td>{}</td><td>{verdict}</td></tr>",
            esc(r.operator.name()),
            esc(r.description)
        );
    }
    h.push_str("</tbody>\n</table>\n");
}

fn variant_row(h: &mut String, si: usize, vi: usize, v: &VariantRun) {
    match &v.outcome {
        Err(e) => {
            let _ = writeln!(
                h,
                "<tr class=\"error\"><td>{}</td><td><span class=\"badge fail\">ERROR</span> could not run: {}</td>\
                 <td>–</td><td>–</td><td>–</td><td>–</td><td>–</td><td>–</td></tr>",
                esc(&v.name),
                esc(e)
            );
        }
        Ok(o) => {
            let s = o.summary();
            let snapshot = v.snapshot.failure().map(|f| esc(&format!("snapshot: {f}")));
            let verdict = if v.passed() {
                "<span class=\"badge pass\">PASS</span>".to_string()
            } else if o.failures.is_empty() {
                // Only the snapshot failed: nothing more to show below.
                format!("<span class=\"badge fail\">FAIL</span> {}", snapshot.clone().unwrap_or_default())
            } else {
                let criteria: Vec<String> = o
                    .failures
                    .iter()
                    .map(|f| esc(&format!("{}: {}", f.criterion, f.what)))
                    .chain(snapshot.clone())
                    .collect();
                format!("<a class=\"badge fail\" href=\"#v-{si}-{vi}\">FAIL</a> {}", criteria.join("<br/>"))
            };
            let class = if v.passed() { "pass" } else { "fail" };
            let _ = writeln!(
                h,
                "<tr class=\"{class}\"><td>{}</td><td>{verdict}</td><td>{}</td><td class=\"num\">{}</td><td>{}</td>\
                 <td class=\"num\">{}</td><td class=\"num\">{}</td><td class=\"num\">{}</td></tr>",
                esc(&v.name),
                if s.stage1_cbv_hit_ego { "yes" } else { "no" },
                opt(s.stage1_min_gap_m, 2),
                esc(&stage2_text(o)),
                opt(s.stage2_min_gap_m, 2),
                opt(s.stage2_min_ttc_s, 1),
                opt(s.stage2_off_road_s, 1),
            );
        }
    }
}

fn failing_variant_html(
    h: &mut String,
    si: usize,
    vi: usize,
    v: &VariantRun,
    o: &VariantOutcome,
    dir: &Path,
    pictures: &mut Vec<(PathBuf, String)>,
) {
    // The variant is named after its file; the picture and the recording
    // after the scene's own id (a WOMD shard's scenario id): show both.
    let source = &o.scenario.source.path;
    let file = source.file_name().map_or_else(|| source.display().to_string(), |f| f.to_string_lossy().into_owned());
    let _ = write!(
        h,
        "<article class=\"failing\" id=\"v-{si}-{vi}\">\n<h3>{} <span class=\"scene\">scenario {} from {}</span></h3>\n\
         <ul class=\"failures\">",
        esc(&v.name),
        esc(&o.scenario.id),
        esc(&file)
    );
    for f in &o.failures {
        let _ = write!(h, "<li>✗ <b>{}</b>: {}</li>", esc(&f.criterion), esc(&f.what));
    }
    let s = o.summary();
    if let Some(shrunk) = &s.shrunk {
        let _ = write!(
            h,
            "<li>shrunk: {}; the recording and picture show the shrunk variant ({}), the variant as made is \
             beside them (<code>.unshrunk</code>)</li>",
            esc(&shrunk.describe()),
            esc(&shrunk.failure)
        );
    }
    if let Some(why) = &s.not_shrunk {
        let _ = write!(h, "<li>not shrunk: {}</li>", esc(why));
    }
    let _ = writeln!(
        h,
        "</ul>\n<p class=\"what\">stage 1 (ego replays its log, the adversary drives CBV {}): CBV hit the ego: {}, \
         closest gap {} m · stage 2 (planner {} drives ego {}): {}, closest gap to the CBV {} m (conflict reached \
         the ego: {}), closest gap {} m, min TTC {} s, ended: {}</p>",
        esc(s.cbv.as_deref().unwrap_or("none")),
        if s.stage1_cbv_hit_ego { "yes" } else { "no" },
        opt(s.stage1_min_gap_m, 2),
        esc(&s.planner),
        esc(&s.ego),
        esc(&stage2_text(o)),
        opt(s.stage2_min_gap_to_cbv_m, 2),
        if s.conflict_reached { "yes" } else { "no" },
        opt(s.stage2_min_gap_m, 2),
        opt(s.stage2_min_ttc_s, 1),
        esc(&s.stage2_termination),
    );

    // Links: the recording (relative to the page) and the picture.
    h.push_str("<p class=\"links\">");
    match &v.artefacts {
        Some(Ok(a)) => {
            let rel = relative_to(dir, &a.mcap);
            let _ = write!(
                h,
                "recording: <a class=\"mcap\" href=\"{}\">{}</a> (open in Foxglove, 3D panel)",
                esc(&url_path(&rel)),
                esc(&a.mcap.display().to_string())
            );
            if let Some(stderr) = &a.stderr {
                let rel = relative_to(dir, stderr);
                let _ = write!(
                    h,
                    " · planner stderr: <a class=\"stderr\" href=\"{}\">{}</a>",
                    esc(&url_path(&rel)),
                    esc(&stderr.display().to_string())
                );
            }
            if let Some(witness) = &a.witness {
                let _ = write!(h, " · closed-loop feasibility witness: {}", esc(witness.verdict().describe()));
            }
        }
        Some(Err(e)) => {
            let _ = write!(h, "recording: could not be written: {}", esc(e));
        }
        None => h.push_str("recording: none was written"),
    }
    let picture = crate::harness::artefacts::relative_path(Path::new("pictures"), &v.name)
        .map(|rel| Path::new("pictures").join(rel).with_extension("svg"));
    let img = match &picture {
        Ok(rel) => {
            // The witness found when the artefacts were written, drawn again here.
            let witness = match &v.artefacts {
                Some(Ok(a)) => a.witness.as_ref().and_then(WitnessArtefact::path).map_or(&[][..], std::slice::from_ref),
                _ => &[],
            };
            let svg = record::render_rollout_svg_with(&o.scenario, &o.stage2, witness, &SvgOptions::default());
            pictures.push((dir.join(rel), svg));
            let href = esc(&url_path(rel));
            let _ = write!(h, " · picture: <a href=\"{href}\">{}</a>", esc(&rel.display().to_string()));
            format!("<img class=\"picture\" src=\"{href}\" alt=\"picture of {}\"/>", esc(&v.name))
        }
        Err(e) => format!("<p>no picture: {}</p>", esc(&e.to_string())),
    };
    // Stage 1 beside it: the conflict as the adversary made it.
    let stage1_img = picture.ok().map(|rel| {
        let rel = rel.with_extension("stage1.svg");
        // Stage 1's escape found when the artefacts were written, drawn again here.
        let escape = match &v.artefacts {
            Some(Ok(a)) => a.stage1_escape.as_slice(),
            _ => &[],
        };
        let svg = record::render_rollout_svg_with(&o.scenario, &o.stage1, escape, &SvgOptions::default());
        pictures.push((dir.join(&rel), svg));
        let href = esc(&url_path(&rel));
        let _ = write!(h, " · stage 1: <a class=\"stage1\" href=\"{href}\">{}</a>", esc(&rel.display().to_string()));
        format!("<img class=\"picture\" src=\"{href}\" alt=\"stage 1 of {}\"/>", esc(&v.name))
    });
    h.push_str("</p>\n<div class=\"views\">\n");
    let _ = writeln!(
        h,
        "<figure>{img}<figcaption>the picture: paths of the whole rollout, boxes at the ego's collision (or the \
         last step)</figcaption></figure>"
    );
    if let Some(stage1_img) = stage1_img {
        let _ = writeln!(
            h,
            "<figure>{stage1_img}<figcaption>stage 1: {}, the conflict as the adversary made \
             it</figcaption></figure>",
            crate::harness::artefacts::STAGE1_SHOWS
        );
    }

    let animation = RolloutAnimation::of_rollout(&o.scenario, &o.stage2);
    // `<`, `>` and `&` only occur inside JSON strings, where the escapes
    // mean the same: no id can close the script element or break the markup.
    let json = serde_json::to_string(&animation)
        .unwrap_or_else(|_| "null".into())
        .replace('<', "\\u003c")
        .replace('>', "\\u003e")
        .replace('&', "\\u0026");
    let _ = write!(
        h,
        "<figure class=\"player\" data-variant=\"{}\">\n<svg class=\"scene\" xmlns=\"http://www.w3.org/2000/svg\" \
         role=\"img\" aria-label=\"stage 2 of {}\"></svg>\n<div class=\"controls\"><button type=\"button\" \
         class=\"play\">▶ play</button><input type=\"range\" class=\"step\" min=\"0\" max=\"0\" value=\"0\" \
         aria-label=\"step\"/><output class=\"time\"></output><label><input type=\"checkbox\" class=\"follow\" \
         checked=\"checked\"/> follow the ego</label></div>\n<figcaption><span class=\"key ego\"></span>ego \
         <span class=\"key cbv\"></span>CBV <span class=\"key other\"></span>other agents \
         <span class=\"key collided\"></span>collided · stage 2, step by step</figcaption>\n\
         <script type=\"application/json\" class=\"rollout\">{json}</script>\n</figure>\n</div>\n</article>\n",
        esc(&v.name),
        esc(&v.name),
    );
}

/// The page's style sheet (colours as in the SVG pictures), an asset file.
const STYLE: &str = include_str!("review_page/style.css");

/// Shows script errors on the page (a test looks for them).
const ERROR_SCRIPT: &str = include_str!("review_page/errors.js");

/// Builds each failing variant's animated view from its JSON data.
const PLAYER_SCRIPT: &str = include_str!("review_page/player.js");

#[cfg(test)]
mod tests {
    use super::*;
    use crate::harness::report::tests_support::{failing_variant, passing_run};
    use crate::harness::report::{RunResults, SuiteLoadFailure};

    fn results() -> RunResults {
        let mut run = passing_run();
        run.name = "un<i>t".into();
        run.variants.push(failing_variant("unit"));
        run.warnings = vec!["s.yaml:3:1: no <b>adversary</b>".into()];
        RunResults {
            load_failures: vec![SuiteLoadFailure { file: "typo.yaml".into(), message: "</script><b>".into() }],
            suites: vec![run],
        }
    }

    #[test]
    fn text_is_escaped_and_the_failing_variant_gets_a_picture_and_frames() {
        let mut pictures = Vec::new();
        let html = page_html(&results(), Path::new("/tmp/page"), &mut pictures);
        roxmltree::Document::parse_with_options(
            &html,
            roxmltree::ParsingOptions { allow_dtd: true, ..Default::default() },
        )
        .expect("the page is well-formed XML");
        assert!(html.contains("un&lt;i&gt;t") && !html.contains("un<i>t"), "suite name not escaped");
        assert!(html.contains("&lt;/script&gt;&lt;b&gt;") && !html.contains("</script><b>"));
        // The spec's warning, escaped, under its suite's heading.
        let warning = "<p class=\"spec-warning\">warning: s.yaml:3:1: no &lt;b&gt;adversary&lt;/b&gt;</p>";
        assert!(html.contains(warning) && html.find(warning) < html.find("<table class=\"variants\">"), "{html}");
        // Stage 2's picture, and stage 1's beside it.
        assert_eq!(pictures.len(), 2);
        assert_eq!(pictures[0].0, Path::new("/tmp/page/pictures/unit/crossing/seed-1.svg"));
        assert!(html.contains("src=\"pictures/unit/crossing/seed-1.svg\""));
        assert_eq!(pictures[1].0, Path::new("/tmp/page/pictures/unit/crossing/seed-1.stage1.svg"));
        assert!(html.contains("class=\"stage1\" href=\"pictures/unit/crossing/seed-1.stage1.svg\""), "{html}");
        assert!(pictures[1].1.contains("planner "), "the stage-1 picture names its planner");
        // The recording link is relative to the page folder.
        let rel = relative_to(Path::new("/tmp/page"), &std::path::absolute("out/unit/crossing/seed-1.mcap").unwrap());
        assert!(html.contains(&format!("href=\"{}\"", url_path(&rel))), "{html}");
        // One player, with every frame of the rollout.
        assert_eq!(html.matches("class=\"player\"").count(), 1);
        let json = html.split("class=\"rollout\">").nth(1).unwrap().split("</script>").next().unwrap();
        let v: serde_json::Value = serde_json::from_str(json).unwrap();
        let run = results();
        let o = run.suites[0].variants[1].outcome.as_ref().unwrap();
        assert_eq!(v["frames"].as_array().unwrap().len(), o.stage2.states.len());
        assert_eq!(v["agents"][0]["role"], "ego");
        // Both variants are in the table.
        assert!(html.contains(">unit::crossing::seed-0<") && html.contains(">unit::crossing::seed-1<"));
        // The failing variant's heading names the scene's own id and file too.
        let scene = &o.scenario;
        let file = scene.source.path.file_name().unwrap().to_string_lossy();
        assert!(html.contains(&format!("<span class=\"scene\">scenario {} from {file}</span>", scene.id)), "{html}");
    }

    #[test]
    fn relative_links_and_url_paths() {
        assert_eq!(relative_to(Path::new("/a/b/page"), Path::new("/a/c/x.mcap")), Path::new("../../c/x.mcap"));
        assert_eq!(relative_to(Path::new("/a/b"), Path::new("/a/b/../b/x")), Path::new("x"));
        assert_eq!(url_path(Path::new("../a b/#1?.mcap")), "../a%20b/%231%3F.mcap");
    }

    #[test]
    fn a_folder_of_other_files_is_refused_and_an_earlier_page_replaced() {
        let tmp = tempfile::Builder::new().prefix("safer-review-page-unit-").tempdir().unwrap();
        let dir = tmp.path().join("page");
        assert!(check_folder(&dir).is_ok(), "missing folder");
        std::fs::create_dir_all(&dir).unwrap();
        assert!(check_folder(&dir).is_ok(), "empty folder");
        std::fs::write(dir.join("notes.txt"), "mine").unwrap();
        let err = check_folder(&dir).unwrap_err();
        assert!(err.to_string().contains("holds other files"), "{err}");
        std::fs::remove_file(dir.join("notes.txt")).unwrap();
        let page = write_review_page(&dir, &results()).unwrap();
        assert!(dir.join("pictures/unit/crossing/seed-1.svg").is_file());
        std::fs::write(dir.join("notes.txt"), "mine").unwrap();
        // An earlier page marks the folder as the page's own.
        assert!(check_folder(&dir).is_ok());
        assert!(write_review_page(&dir, &results()).is_ok());
        assert!(std::fs::read_to_string(&page).unwrap().contains(GENERATOR));
        let file = dir.join("notes.txt");
        assert!(matches!(check_folder(&file), Err(RecordError::InvalidPath { .. })));
        std::fs::remove_dir_all(&dir).ok();
    }
}
