//! The headline tables of `docs/benchmarks.md` and the README quote the
//! committed outputs of `docs/evaluation/regenerate.sh`: when an output is
//! regenerated and a table is not rewritten from it (or the other way
//! round), these tests name the row and the figure that differ.

use std::collections::BTreeMap;

/// A file of the repository, as text.
fn repo_file(path: &str) -> String {
    let full = format!("{}/{path}", repo_root!());
    std::fs::read_to_string(&full).unwrap_or_else(|e| panic!("reading {full}: {e}"))
}

/// The benchmarks and the record of how the adversary's settings were
/// measured (`docs/research/2026-12-adversary-settings.md`), as one text:
/// each table is found by markers that appear once across both.
fn measured_docs() -> String {
    repo_file("docs/benchmarks.md") + "\n" + &repo_file("docs/research/2026-12-adversary-settings.md")
}

/// An output's rows of one table: method → its cells after the method's
/// name, split on whitespace (the first table of the output whose header
/// line starts with `method` and holds `header_word`; its rows end at the
/// first line that is not a row).
fn output_table(output: &str, header_word: &str) -> BTreeMap<String, Vec<String>> {
    let mut lines = output.lines().skip_while(|l| !(l.starts_with("method") && l.contains(header_word)));
    lines.next().unwrap_or_else(|| panic!("no table with {header_word:?} in the output"));
    let mut rows = BTreeMap::new();
    for line in lines {
        let cells: Vec<String> = line.split_whitespace().map(str::to_owned).collect();
        // A row: the method's name, then its cells. A header names some
        // columns in several words, so their count says nothing; the line
        // under a table (blank, a note `word: ...`, a scene's id) is no row.
        let method_name = cells.first().is_some_and(|c| c.chars().all(|c| c.is_ascii_lowercase() || c == '-'));
        if cells.len() < 2 || !method_name || cells.iter().any(|c| c.ends_with(':')) {
            break;
        }
        rows.insert(cells[0].clone(), cells[1..].to_vec());
    }
    assert!(!rows.is_empty(), "the {header_word:?} table has no rows");
    rows
}

/// A set's main evaluation rows (`evaluate-{set}.txt`) with the
/// plain-attention prior's (`evaluate-{set}-no-mda.txt`) beside them.
fn main_evaluation_rows(set: &str) -> BTreeMap<String, Vec<String>> {
    let mut rows = output_table(&repo_file(&format!("docs/evaluation/evaluate-{set}.txt")), "variants");
    rows.extend(output_table(&repo_file(&format!("docs/evaluation/evaluate-{set}-no-mda.txt")), "variants"));
    rows
}

/// The mutant-variants killed, from a kills cell `killed/of`.
fn killed(kills_of: &str) -> &str {
    kills_of.split('/').next().unwrap_or(kills_of)
}

/// The evaluation table's figures of a method: CR, SR, SR-crit, witness,
/// VJ, AJ, YJ (an output's `—` as the docs' `–`).
fn evaluation_figures(rows: &BTreeMap<String, Vec<String>>, method: &str) -> Vec<String> {
    let cells = rows.get(method).unwrap_or_else(|| panic!("no row for {method} in the output"));
    // variants, errors, then the figures.
    cells[2..9].iter().map(|c| c.replace('—', "–")).collect()
}

/// The markdown table rows between the first line containing `from` and
/// the next line containing `to`, as cells (trimmed, between the pipes).
fn markdown_rows(doc: &str, from: &str, to: &str) -> Vec<Vec<String>> {
    section(doc, from, to)
        .iter()
        .filter(|l| l.starts_with('|') && !l.starts_with("| ---"))
        .map(|l| l.trim().trim_matches('|').split('|').map(|c| c.trim().to_owned()).collect())
        .collect()
}

/// The lines of `doc` after the first holding `from`, up to the next
/// holding `to`; there must be some.
fn section<'a>(doc: &'a str, from: &str, to: &str) -> Vec<&'a str> {
    let section: Vec<&str> =
        doc.lines().skip_while(|l| !l.contains(from)).skip(1).take_while(|l| !l.contains(to)).collect();
    assert!(!section.is_empty(), "no section from {from:?} to {to:?}");
    section
}

/// The method a cell names: its first `backticked` word.
fn method_of(cell: &str) -> Option<&str> {
    let start = cell.find('`')? + 1;
    let end = start + cell[start..].find('`')?;
    Some(&cell[start..end])
}

/// `a / b / c` as its parts.
fn parts(cell: &str) -> Vec<String> {
    cell.split('/').map(|p| p.trim().to_owned()).collect()
}

#[test]
fn the_main_evaluation_table_quotes_the_womd_interactive_outputs() {
    let doc = measured_docs();
    let output = main_evaluation_rows("womd-interactive");
    let rows = markdown_rows(&doc, "## Dual-stage evaluation", "**Trust region**");
    let mut checked = 0;
    for row in rows.iter().filter(|r| r[0].starts_with('`')) {
        let method = method_of(&row[0]).unwrap();
        // CR, SR, SR-crit, witness, then VJ / AJ / YJ in one cell.
        let mut quoted = row[1..5].to_vec();
        quoted.extend(parts(&row[5]));
        assert_eq!(quoted, evaluation_figures(&output, method), "{method}'s row of the main table");
        checked += 1;
    }
    assert_eq!(checked, 11, "every method of the main table");
}

#[test]
fn the_womd_json_and_ngsim_tables_quote_their_outputs() {
    let doc = measured_docs();
    let outputs = [("WOMD JSON", main_evaluation_rows("womd-json")), ("NGSIM", main_evaluation_rows("ngsim"))];
    let mut checked = 0;
    let mut set = "";
    for row in markdown_rows(&doc, "**WOMD JSON and NGSIM**", "CR(`safer`) ≥ 2 × CR(`prior`)") {
        if !row[0].is_empty() {
            set = if row[0].starts_with("WOMD JSON") {
                "WOMD JSON"
            } else if row[0].starts_with("NGSIM") {
                "NGSIM"
            } else {
                ""
            };
        }
        let Some(method) = method_of(&row[1]) else { continue };
        let (_, output) = outputs.iter().find(|(s, _)| *s == set).unwrap_or_else(|| panic!("no set for {row:?}"));
        let mut quoted = row[2..6].to_vec();
        quoted.extend(parts(&row[6]));
        assert_eq!(quoted, evaluation_figures(output, method), "{set}, {method}");
        checked += 1;
    }
    assert_eq!(checked, 22, "both sets' rows");
}

/// Checks one mutation table of the benchmarks (the section from `from` to
/// `to`) against its outputs: CR, SR, passed, kills (with the held-out
/// scenes'), ×log and ×prior of every row, found by the table's header.
/// `outputs`: each set's label as its first cell reads, and the outputs
/// (under `docs/evaluation/`) whose rows it quotes, the first holding the
/// method answering. Returns the rows checked.
fn check_mutation_table(from: &str, to: &str, outputs: &[(&str, &[&str])]) -> usize {
    let doc = measured_docs();
    let rows = markdown_rows(&doc, from, to);
    let header = &rows[0];
    let column =
        |name: &str| header.iter().position(|c| c == name).unwrap_or_else(|| panic!("no {name} in {header:?}"));
    let columns = ["CR", "SR", "passed", "kills (held out)", "×log", "×prior"].map(column);
    let mut checked = 0;
    let mut set: Option<(&str, Vec<_>)> = None;
    for row in &rows[1..] {
        if !row[0].is_empty() {
            let (label, files) = outputs
                .iter()
                .find(|(label, _)| row[0] == *label)
                .unwrap_or_else(|| panic!("no output named for the set {:?}", row[0]));
            let tables = files
                .iter()
                .map(|file| {
                    let text = repo_file(&format!("docs/evaluation/{file}"));
                    (output_table(&text, "variants"), output_table(&text, "passed"))
                })
                .collect();
            set = Some((label, tables));
        }
        let Some(method) = method_of(&row[1]) else { continue };
        let (label, tables) = set.as_ref().unwrap_or_else(|| panic!("no set for {row:?}"));
        let (main, kills) = tables
            .iter()
            .find(|(main, kills)| main.contains_key(method) && kills.contains_key(method))
            .unwrap_or_else(|| panic!("{label}: no output has {method}"));
        let figures = evaluation_figures(main, method);
        let kill_cells = &kills[method];
        // passed, kills/of, `|`, held out, ×log, ×prior. The ten-seed table
        // quotes the kills without what they are out of.
        let quoted: Vec<&String> = columns.iter().map(|&c| &row[c]).collect();
        let kills_of = if quoted[3].contains('/') && quoted[3].find('/') < quoted[3].find('(') {
            kill_cells[1].clone()
        } else {
            killed(&kill_cells[1]).to_owned()
        };
        let kills_quoted = format!("{kills_of} ({})", kill_cells[3]);
        let expected = [&figures[0], &figures[1], &kill_cells[0], &kills_quoted, &kill_cells[4], &kill_cells[5]]
            .map(String::as_str);
        let quoted: Vec<String> = quoted.iter().map(|c| c.replace("**", "")).collect();
        assert_eq!(quoted, expected, "{label}, {method}: CR, SR, passed, kills, ×log, ×prior");
        checked += 1;
    }
    checked
}

#[test]
fn the_three_seed_mutation_tables_quote_their_outputs() {
    let evasive = check_mutation_table(
        "**The evasive planner** (scenes × seeds)",
        "**The Python lane follower**",
        &[
            ("WOMD interactive (54 × 3)", &["mutants/mutants-womd-interactive-evasive.txt"]),
            ("WOMD JSON (65 × 3)", &["mutants/mutants-womd-json-evasive.txt"]),
            ("NGSIM (69 × 3)", &["mutants/mutants-ngsim-evasive.txt"]),
        ],
    );
    assert_eq!(evasive, 21, "the evasive planner's rows");
    let lane_follower = check_mutation_table(
        "**The Python lane follower**",
        "The goal is 2× log replay's kills",
        &[
            ("WOMD interactive (54 × 2)", &["mutants/mutants-womd-interactive-lane-follower.txt"]),
            ("NGSIM (69 × 2)", &["mutants/mutants-ngsim-lane-follower.txt"]),
        ],
    );
    assert_eq!(lane_follower, 10, "the lane follower's rows");
}

#[test]
fn the_ten_seed_mutation_table_quotes_its_outputs() {
    let rows = check_mutation_table(
        "### Over ten seeds",
        "On WOMD interactive `safer-in-path` kills",
        &[
            ("WOMD interactive (54 × 10)", &["ten-seeds/mutants-womd-interactive-evasive.txt"]),
            ("NGSIM, n = 60 (69 × 10)", &["ten-seeds/mutants-ngsim-evasive-n60.txt"]),
            (
                "NGSIM, n = 60, the recorded cars braking for the ego (69 × 10)",
                &["recorded-cars-braking/mutants-ngsim-evasive-n60-ten-seeds.txt"],
            ),
            (
                "WOMD interactive, the Python lane follower (54 × 10)",
                &["ten-seeds/mutants-womd-interactive-lane-follower.txt"],
            ),
            (
                "WOMD interactive, n = 60, the lane follower, the recorded cars braking for the ego (54 × 10)",
                &["ten-seeds/mutants-womd-interactive-lane-follower-n60-reactive.txt"],
            ),
            (
                "NGSIM, n = 60, the Python lane follower (69 × 10)",
                &[
                    "ten-seeds/mutants-ngsim-lane-follower-n60.txt",
                    "ten-seeds/mutants-ngsim-lane-follower-n60-cut-in.txt",
                ],
            ),
            (
                "NGSIM, n = 60, the lane follower, the recorded cars braking for the ego (69 × 10)",
                &["ten-seeds/mutants-ngsim-lane-follower-n60-reactive.txt"],
            ),
        ],
    );
    assert_eq!(rows, 25, "every row of the ten-seed table");
}

#[test]
fn the_readme_results_table_quotes_the_womd_interactive_outputs() {
    let readme = repo_file("README.md");
    // Each output with its main table.
    let outputs = ["evaluate-womd-interactive.txt", "evaluate-womd-interactive-default.txt"].map(|file| {
        let output = repo_file(&format!("docs/evaluation/readme-results/{file}"));
        (output_table(&output, "variants"), output)
    });
    let mut checked = 0;
    for row in markdown_rows(&readme, "## Results", "CR: share of variants") {
        let Some(method) = method_of(&row[0]) else { continue };
        // The suites' method (over 28 behaviours, no contact from behind)
        // is its own run.
        let (table, output) = &outputs[usize::from(row[0].contains("no contact from behind"))];
        let figures = evaluation_figures(table, method);
        let plausibility = labelled_row(output, "CBV-bg coll", method);
        // CR, SR, SR-crit, witness, then VJ / AJ, then at fault / off road /
        // tailgating (the plausibility table's last column).
        let mut quoted = row[1..5].to_vec();
        quoted.extend(parts(&row[5]));
        quoted.extend(parts(&row[6]));
        let tailgating = plausibility.last().expect("a tailgating column").clone();
        let expected = [&figures[..6], &[plausibility[1].clone(), plausibility[3].clone(), tailgating][..]].concat();
        assert_eq!(quoted, expected, "the README's {method} row");
        checked += 1;
    }
    assert!(checked >= 12, "{checked} rows");
}

#[test]
fn the_trust_region_sweep_quotes_its_outputs() {
    let doc = measured_docs();
    let rows =
        markdown_rows(&doc, "**Trust region** (`safer evaluate --scenes data:womd-interactive", "`safer` gains most");
    let methods = ["safer", "safer-in-path", "safer-distinct", "safer-lookahead"];
    let mut checked = 0;
    for row in rows.iter().filter(|r| r[0].chars().all(|c| c.is_ascii_digit())) {
        // n = 20 is the main table's run.
        let file = match row[0].as_str() {
            "20" => "evaluate-womd-interactive.txt".to_owned(),
            n => format!("evaluate-womd-interactive-n{n}.txt"),
        };
        let output = output_table(&repo_file(&format!("docs/evaluation/{file}")), "variants");
        for (i, method) in methods.iter().enumerate() {
            let figures = evaluation_figures(&output, method);
            assert_eq!(parts(&row[1 + i]), figures[..3], "n = {}, {method}: CR / SR / SR-crit", row[0]);
        }
        // VJ / AJ / YJ of safer, then of safer-in-path.
        let realism: Vec<String> = row[5].split(',').flat_map(parts).collect();
        let expected: Vec<String> =
            ["safer", "safer-in-path"].iter().flat_map(|m| evaluation_figures(&output, m)[4..7].to_vec()).collect();
        assert_eq!(realism, expected, "n = {}: VJ / AJ / YJ", row[0]);
        // Seconds a variant, to two places.
        let seconds: Vec<String> = row[6].split(',').map(|c| c.trim().to_owned()).collect();
        let expected: Vec<String> = ["safer", "safer-in-path", "safer-lookahead"]
            .iter()
            .map(|m| format!("{:.2}", output[*m][9].parse::<f64>().expect("s/variant")))
            .collect();
        assert_eq!(seconds, expected, "n = {}: s/variant", row[0]);
        checked += 1;
    }
    assert_eq!(checked, 4, "n = 10, 20, 50, 100");
}

#[test]
fn the_table_without_the_approach_phase_quotes_its_outputs() {
    let doc = measured_docs();
    let rows = markdown_rows(&doc, "**Without the approach phase**", "On WOMD interactive the approach phase costs");
    // The set's label, its folder under approach-none/, its main outputs' name.
    let sets = [
        ("WOMD interactive", "womd-interactive", "womd-interactive"),
        ("WOMD JSON", "womd-json", "womd-json"),
        ("NGSIM", "commonroad-ngsim", "ngsim"),
    ];
    let mut checked = 0;
    for row in rows.iter().skip(1) {
        let (_, unseeded, seeded) =
            sets.iter().find(|(label, ..)| row[0].starts_with(label)).unwrap_or_else(|| panic!("{row:?}"));
        let first_token =
            output_table(&repo_file(&format!("docs/evaluation/approach-none/evaluate-{unseeded}.txt")), "variants");
        let main = main_evaluation_rows(seeded);
        let cr = |table: &BTreeMap<String, Vec<String>>, method: &str| evaluation_figures(table, method)[0].clone();
        let wide = evaluation_figures(&first_token, "no-trust-region");
        let expected = [
            cr(&first_token, "safer"),
            cr(&first_token, "safer-inattentive"),
            cr(&first_token, "safer-lookahead"),
            cr(&first_token, "no-lfr"),
            format!("{} (SR {})", wide[0], wide[1]),
            cr(&main, "safer"),
            cr(&main, "prior"),
        ];
        assert_eq!(row[1..], expected[..], "{}", row[0]);
        checked += 1;
    }
    assert_eq!(checked, 3, "the three sets");
}

#[test]
fn the_kill_ratio_summary_quotes_the_three_seed_outputs() {
    let doc = measured_docs();
    let rows = markdown_rows(&doc, "The goal is 2× log replay's kills", "Many of every method's kills");
    let outputs = [
        ("evasive, WOMD interactive", "mutants/mutants-womd-interactive-evasive.txt"),
        ("evasive, WOMD JSON", "mutants/mutants-womd-json-evasive.txt"),
        ("evasive, NGSIM", "mutants/mutants-ngsim-evasive.txt"),
        ("lane follower, WOMD interactive", "mutants/mutants-womd-interactive-lane-follower.txt"),
        ("lane follower, NGSIM", "mutants/mutants-ngsim-lane-follower.txt"),
    ];
    let mut checked = 0;
    for row in rows.iter().skip(1) {
        let row: Vec<String> = row.iter().map(|c| c.replace("**", "")).collect();
        let (_, file) = outputs.iter().find(|(label, _)| row[0] == *label).unwrap_or_else(|| panic!("{row:?}"));
        let kills = output_table(&repo_file(&format!("docs/evaluation/{file}")), "passed");
        // passed, kills/of, `|`, held out, ×log, ×prior, scene kills, ×log, ×prior, by CBV.
        let cells = |method: &str| kills.get(method).unwrap_or_else(|| panic!("{file}: no {method}")).clone();
        let in_path = cells("safer-in-path");
        assert_eq!(parts(&row[1]), in_path[4..6], "{}: safer-in-path's kills ×log / ×prior", row[0]);
        assert_eq!(parts(&row[2]), in_path[7..9], "{}: its scene kills ×log / ×prior", row[0]);
        let by_cbv: Vec<String> = row[3].split(',').map(|c| c.trim().to_owned()).collect();
        let expected: Vec<String> = ["safer-in-path", "log", "prior"].iter().map(|m| cells(m)[9].clone()).collect();
        assert_eq!(by_cbv, expected, "{}: kills by the CBV", row[0]);
        assert_eq!(parts(&row[4]), cells("safer")[4..6], "{}: safer's kills ×log / ×prior", row[0]);
        checked += 1;
    }
    assert_eq!(checked, 5, "every table's row");
}

#[test]
fn the_reactive_background_table_quotes_its_outputs() {
    let doc = measured_docs();
    let rows = markdown_rows(&doc, "**Reactive background**", "With the reactive background");
    let outputs = |set: &str| {
        let replay = main_evaluation_rows(set);
        let reactive = output_table(&repo_file(&format!("docs/evaluation/evaluate-{set}-reactive.txt")), "variants");
        (replay, reactive)
    };
    let sets = [("WOMD interactive", outputs("womd-interactive")), ("NGSIM", outputs("ngsim"))];
    let mut set = None;
    let mut checked = 0;
    for row in &rows {
        if let Some((_, tables)) = sets.iter().find(|(label, _)| row[0] == *label) {
            set = Some(tables);
        }
        let Some(method) = method_of(&row[1]) else { continue };
        let (replay, reactive) = set.unwrap_or_else(|| panic!("no set for {row:?}"));
        let (before, after) = (evaluation_figures(replay, method), evaluation_figures(reactive, method));
        // CR, SR, SR-crit, witness as `replay → reactive` (log replay's CR
        // and the columns it has no figure for read `–`).
        for (column, cell) in row[2..6].iter().enumerate() {
            let expected = match (before[column].as_str(), after[column].as_str()) {
                ("–", "–") => "–".to_owned(),
                _ if method == "log" && column == 0 => "–".to_owned(),
                (b, a) => format!("{b} → {a}"),
            };
            assert_eq!(*cell, expected, "{}, {method}: column {}", row[0], column + 2);
        }
        checked += 1;
    }
    assert_eq!(checked, 20, "both sets' ten methods");
}

/// Checks a table whose rows name their run in the first cell (and the
/// trust region in the second): CR, SR, witness, kills (held out), ×log
/// and ×prior of the method (the third cell's, or `method` for every row)
/// against the output `outputs` names for (first cell, n). Returns the
/// rows checked.
fn check_run_table(from: &str, to: &str, method: Option<&str>, outputs: &[(&str, &str, &str)]) -> usize {
    let doc = measured_docs();
    let rows = markdown_rows(&doc, from, to);
    let header = &rows[0];
    let column =
        |name: &str| header.iter().position(|c| c == name).unwrap_or_else(|| panic!("no {name} in {header:?}"));
    let columns = ["CR", "SR", "witness", "kills (held out)", "×log", "×prior"].map(column);
    let mut checked = 0;
    for row in &rows[1..] {
        let (_, _, file) = outputs
            .iter()
            .find(|(label, n, _)| row[0] == *label && row[1] == *n)
            .unwrap_or_else(|| panic!("no output named for {:?}, n = {}", row[0], row[1]));
        let method = method.or_else(|| method_of(&row[2])).unwrap_or_else(|| panic!("no method in {row:?}"));
        let text = repo_file(&format!("docs/evaluation/{file}"));
        let figures = evaluation_figures(&output_table(&text, "variants"), method);
        let kills = output_table(&text, "passed");
        let kill_cells = kills.get(method).unwrap_or_else(|| panic!("{file}: no {method}"));
        let expected = [
            figures[0].clone(),
            figures[1].clone(),
            figures[3].clone(),
            format!("{} ({})", killed(&kill_cells[1]), kill_cells[3]),
            kill_cells[4].clone(),
            kill_cells[5].clone(),
        ];
        let quoted: Vec<String> = columns.iter().map(|&c| row[c].replace("**", "")).collect();
        assert_eq!(quoted, expected, "{}, n = {}, {method}: CR, SR, witness, kills, ×log, ×prior", row[0], row[1]);
        checked += 1;
    }
    checked
}

#[test]
fn the_wide_region_and_cut_in_tables_quote_their_outputs() {
    let wide = check_run_table(
        "## Trust region on the freeway",
        "- **On NGSIM n = 60 meets the kill goal",
        Some("safer-in-path"),
        &[
            ("evasive, NGSIM", "20", "mutants-ngsim-evasive.txt"),
            ("evasive, NGSIM", "60", "mutants-ngsim-evasive-n60.txt"),
            ("evasive, NGSIM", "100", "mutants-ngsim-evasive-n100.txt"),
            ("lane follower, NGSIM", "20", "mutants-ngsim-lane-follower.txt"),
            ("lane follower, NGSIM", "60", "mutants-ngsim-lane-follower-n60.txt"),
            ("lane follower, NGSIM", "100", "mutants-ngsim-lane-follower-n100.txt"),
            ("evasive, WOMD interactive", "20", "mutants-womd-interactive-evasive.txt"),
            ("evasive, WOMD interactive", "60", "mutants-womd-interactive-evasive-n60.txt"),
            ("evasive, WOMD interactive", "100", "mutants-womd-interactive-evasive-n100.txt"),
            ("lane follower, WOMD interactive", "20", "mutants-womd-interactive-lane-follower.txt"),
            ("lane follower, WOMD interactive", "60", "mutants-womd-interactive-lane-follower-n60.txt"),
        ],
    );
    assert_eq!(wide, 11, "the wide-region table's rows");
    let cut_in = check_run_table(
        "## Cut-ins that are made: `safer-cut-in`",
        "- **Cut-ins.**",
        None,
        &[
            ("evasive, NGSIM", "60", "cut-in/mutants-ngsim-evasive-n60.txt"),
            ("evasive, NGSIM, `--seed 1000`", "60", "cut-in/mutants-ngsim-evasive-n60-seed1000.txt"),
            ("lane follower, NGSIM", "60", "cut-in/mutants-ngsim-lane-follower-n60.txt"),
            ("evasive, WOMD interactive", "20", "cut-in/mutants-womd-interactive-evasive.txt"),
            ("evasive, WOMD interactive, `--seed 1000`", "20", "cut-in/mutants-womd-interactive-evasive-seed1000.txt"),
            ("evasive, WOMD interactive", "60", "cut-in/mutants-womd-interactive-evasive-n60.txt"),
            ("lane follower, WOMD interactive", "20", "cut-in/mutants-womd-interactive-lane-follower.txt"),
        ],
    );
    assert_eq!(cut_in, 14, "the cut-in table's rows");
}

/// The WOMD interactive mutation table over 20 behaviours of the draw of
/// seeds a draws table's first cell names (`None` for its other rows).
fn draw_over_20(draw: &str) -> Option<String> {
    match draw {
        "0" => Some("in-path-lookahead/mutants-womd-interactive-evasive.txt".to_owned()),
        "mean" | "---" => None,
        seed => Some(format!("in-path-lookahead/mutants-womd-interactive-evasive-seed{seed}.txt")),
    }
}

/// A method's kills and their ratio to the prior's, `kills (×prior)`, from
/// a mutation output's kills table.
fn kills_and_ratio(kills: &BTreeMap<String, Vec<String>>, method: &str) -> String {
    let cells = &kills[method];
    format!("{} ({})", killed(&cells[1]), cells[5])
}

#[test]
fn the_lookahead_mutation_tables_quote_their_outputs() {
    let doc = measured_docs();
    let files = [
        ("WOMD interactive", "in-path-lookahead/mutants-womd-interactive-evasive.txt"),
        ("WOMD interactive, `--seed 1000`", "in-path-lookahead/mutants-womd-interactive-evasive-seed1000.txt"),
        ("NGSIM", "in-path-lookahead/mutants-ngsim-evasive.txt"),
        ("lane follower, WOMD interactive (2 seeds)", "in-path-lookahead/mutants-womd-interactive-lane-follower.txt"),
    ];
    let kills_of = |file: &str| output_table(&repo_file(&format!("docs/evaluation/{file}")), "passed");
    let mut checked = 0;
    for row in
        markdown_rows(&doc, "Mutation testing (the evasive planner, the CBV closed loop, 3 seeds:", "More collisions")
            .iter()
            .skip(1)
    {
        let (_, file) = files.iter().find(|(label, _)| row[0] == *label).unwrap_or_else(|| panic!("{row:?}"));
        let method = method_of(&row[1]).unwrap();
        let text = repo_file(&format!("docs/evaluation/{file}"));
        let figures = evaluation_figures(&output_table(&text, "variants"), method);
        let kills = &kills_of(file)[method];
        // CR, SR, kills (held out), ×log, ×prior, scene kills, by CBV.
        let expected = [
            &figures[0],
            &figures[1],
            &format!("{} ({})", killed(&kills[1]), kills[3]),
            &kills[4],
            &kills[5],
            &kills[6],
            &kills[9],
        ];
        let quoted: Vec<String> = row[2..9].iter().map(|c| c.replace("**", "")).collect();
        assert_eq!(quoted, expected.map(String::as_str), "{}, {method}", row[0]);
        checked += 1;
    }
    assert_eq!(checked, 8, "the lookahead's mutation rows");
    // The draws of seeds: each method's kills and ×prior, and the prior's kills.
    let mut draws = 0;
    for row in markdown_rows(&doc, "| draw | `safer-in-path` kills (×prior)", "The horizon's variants kill").iter() {
        let Some(file) = draw_over_20(&row[0]) else { continue };
        let kills = kills_of(&file);
        assert_eq!(row[1], kills_and_ratio(&kills, "safer-in-path"), "draw {}", row[0]);
        assert_eq!(row[2], kills_and_ratio(&kills, "safer-in-path-lookahead"), "draw {}", row[0]);
        assert_eq!(row[3], killed(&kills["prior"][1]), "draw {}: the prior", row[0]);
        draws += 1;
    }
    assert_eq!(draws, 4, "four draws of seeds");
}

/// A method's held-out CR in an evaluation output: the first figure of
/// its row in the table after the line starting `held out`.
fn held_out_cr(output: &str, method: &str) -> String {
    let from = output.find("\nheld out").unwrap_or_else(|| panic!("no held-out table in the output"));
    output[from..]
        .lines()
        .map(|l| l.split_whitespace().collect::<Vec<_>>())
        .find(|cells| cells.first() == Some(&method))
        .and_then(|cells| cells.get(1).map(|c| (*c).to_owned()))
        .unwrap_or_else(|| panic!("no held-out row for {method}"))
}

/// An evaluation output's main table, and its text.
fn evaluation_output(file: &str) -> (BTreeMap<String, Vec<String>>, String) {
    let text = repo_file(&format!("docs/evaluation/{file}"));
    (output_table(&text, "variants"), text)
}

#[test]
fn the_lookahead_region_sweep_quotes_its_outputs() {
    let doc = measured_docs();
    // CR, CR held out, SR, SR-crit, witness, VJ / AJ of each region.
    let mut sweep = Vec::new();
    let header = "| n | CR | CR held out | SR | SR-crit | witness | VJ / AJ |";
    for row in markdown_rows(&doc, header, "With any contact, the lookahead over 25 to 30") {
        let file = match row[0].as_str() {
            "---" => continue,
            n => format!("default-sweep/any-n{n}.txt"),
        };
        let (rows, text) = evaluation_output(&file);
        let figures = evaluation_figures(&rows, "safer-in-path-lookahead");
        let mut quoted = vec![row[1].clone()];
        quoted.extend_from_slice(&row[3..6]);
        quoted.extend(parts(&row[6]));
        assert_eq!(quoted, [&figures[..4], &figures[4..6]].concat(), "n = {}", row[0]);
        assert_eq!(row[2], held_out_cr(&text, "safer-in-path-lookahead"), "n = {}: CR held out", row[0]);
        sweep.push(row[0].clone());
    }
    assert_eq!(sweep, ["20", "25", "27", "28", "30", "40", "60", "100"], "the sweep's regions");
}

#[test]
fn the_suites_method_sweep_quotes_its_outputs_with_and_without_the_rule() {
    let doc = repo_file("docs/benchmarks.md");
    let header = "| n | no contact from behind: CR | CR held out | SR | SR-crit | witness | any contact: CR |";
    let mut sweep = Vec::new();
    for row in markdown_rows(&doc, header, "The goal for a suite's default method") {
        if row[0] == "---" {
            continue;
        }
        for (file, cells) in [("sweep", &row[1..6]), ("any", &row[6..11])] {
            let (rows, text) = evaluation_output(&format!("default-sweep/{file}-n{}.txt", row[0]));
            let figures = evaluation_figures(&rows, "safer-in-path-lookahead");
            let label = format!("n = {}, {file}", row[0]);
            assert_eq!([&cells[..1], &cells[2..]].concat(), figures[..4], "{label}");
            assert_eq!(cells[1], held_out_cr(&text, "safer-in-path-lookahead"), "{label}: CR held out");
        }
        sweep.push(row[0].clone());
    }
    assert_eq!(sweep, ["20", "28", "40", "60", "100"], "the sweep's regions");
}

#[test]
fn the_lookahead_mutation_table_over_twenty_eight_behaviours_quotes_its_outputs() {
    let doc = measured_docs();
    let kills_of = |file: &str| output_table(&repo_file(&format!("docs/evaluation/{file}")), "passed");
    let mut rows = Vec::new();
    for row in markdown_rows(&doc, "| draw | `safer-in-path-lookahead`, n = 28 |", "Over 28 behaviours the") {
        let seed = &row[0];
        if !seed.chars().all(|c| c.is_ascii_digit()) {
            continue;
        }
        let (over_28, over_30) = (
            kills_of(&format!("in-path-lookahead/n28/mutants-womd-interactive-evasive-seed{seed}.txt")),
            kills_of(&format!("in-path-lookahead/n30/mutants-womd-interactive-evasive-seed{seed}.txt")),
        );
        let label = format!("draw {seed}");
        assert_eq!(row[1], kills_and_ratio(&over_28, "safer-in-path-lookahead"), "{label}");
        assert_eq!(row[2], held_out_kills(&over_28, "safer-in-path-lookahead"), "{label}: held out");
        assert_eq!(row[3], kills_and_ratio(&over_30, "safer-in-path-lookahead"), "{label}");
        assert_eq!(row[4], kills_and_ratio(&over_30, "safer-in-path"), "{label}");
        // The prior's and log replay's variants do not depend on the region.
        for method in ["prior", "log"] {
            assert_eq!(over_28[method][1], over_30[method][1], "{label}: {method}");
        }
        assert_eq!(row[5], killed(&over_28["prior"][1]), "{label}: the prior");
        assert_eq!(row[6], killed(&over_28["log"][1]), "{label}: log replay");
        rows.push(label);
    }
    assert_eq!(rows, ["draw 0", "draw 1000", "draw 2000", "draw 3000"], "the draws over 28 behaviours");
}

/// A method's kills on the held-out scenes, `k/n`, from a mutation
/// output's kills table.
fn held_out_kills(kills: &BTreeMap<String, Vec<String>>, method: &str) -> String {
    kills[method][3].clone()
}

#[test]
fn the_lookahead_protocol_table_over_thirty_behaviours_quotes_its_outputs() {
    let doc = measured_docs();
    // CR, CR held out, SR, SR-crit, witness, VJ / AJ.
    let mut protocol = 0;
    for row in markdown_rows(&doc, "--trust-region 30`):", "Mutation testing over 30 behaviours") {
        let Some(set) = set_stem(&row[0]) else { continue };
        let method = method_of(&row[1]).unwrap();
        let (rows, text) = evaluation_output(&format!("in-path-lookahead/n30/evaluate-{set}.txt"));
        let figures = evaluation_figures(&rows, method);
        let mut quoted = vec![row[2].clone(), row[4].clone(), row[5].clone(), row[6].clone()];
        quoted.extend(parts(&row[7]));
        assert_eq!(quoted, [&figures[..4], &figures[4..6]].concat(), "{set}, {method}");
        assert_eq!(row[3], held_out_cr(&text, method), "{set}, {method}: CR held out");
        protocol += 1;
    }
    assert_eq!(protocol, 6, "the protocol's rows");
}

#[test]
fn the_lookahead_mutation_tables_over_thirty_behaviours_quote_their_outputs() {
    let mutation = check_mutation_table(
        "Mutation testing over 30 behaviours",
        "On WOMD interactive over the same four draws",
        &[
            ("WOMD interactive", &["in-path-lookahead/n30/mutants-womd-interactive-evasive-seed0.txt"]),
            ("NGSIM", &["in-path-lookahead/n30/mutants-ngsim-evasive.txt"]),
            (
                "lane follower, WOMD interactive (2 seeds)",
                &["in-path-lookahead/n30/mutants-womd-interactive-lane-follower.txt"],
            ),
            ("lane follower, NGSIM (2 seeds)", &["in-path-lookahead/n30/mutants-ngsim-lane-follower.txt"]),
        ],
    );
    assert_eq!(mutation, 8, "the mutation rows over 30 behaviours");
    // The draws of seeds: kills (×prior) over 20 and over 30, and the prior's kills.
    let doc = measured_docs();
    let kills_of = |file: &str| output_table(&repo_file(&format!("docs/evaluation/{file}")), "passed");
    let mut draws = 0;
    for row in markdown_rows(&doc, "| draw | `safer-in-path`, n = 20 |", "Over four draws").iter() {
        let Some(over_20) = draw_over_20(&row[0]) else { continue };
        let (over_20, over_30) = (
            kills_of(&over_20),
            kills_of(&format!("in-path-lookahead/n30/mutants-womd-interactive-evasive-seed{}.txt", row[0])),
        );
        assert_eq!(row[1], kills_and_ratio(&over_20, "safer-in-path"), "draw {}", row[0]);
        assert_eq!(row[2], kills_and_ratio(&over_30, "safer-in-path"), "draw {}", row[0]);
        assert_eq!(row[3], kills_and_ratio(&over_30, "safer-in-path-lookahead"), "draw {}", row[0]);
        // The prior's variants do not depend on the region.
        assert_eq!(over_20["prior"][1], over_30["prior"][1], "draw {}: the prior", row[0]);
        assert_eq!(row[4], killed(&over_30["prior"][1]), "draw {}: the prior", row[0]);
        draws += 1;
    }
    assert_eq!(draws, 4, "four draws of seeds");
}

/// Checks a row of a feasibility-scope table (set, method, scope, CR, CR
/// held out, SR, SR-crit, witness, VJ / AJ) against `method`'s figures in
/// the output `file`, which must say `run` when given; its label and the
/// output's text.
fn check_scope_row(row: &[String], method: &str, file: &str, run: Option<&str>) -> (String, String) {
    let (rows, text) = evaluation_output(file);
    if let Some(run) = run {
        assert!(text.contains(run), "{file} is not a run with {run}");
    }
    let figures = evaluation_figures(&rows, method);
    let mut quoted: Vec<String> = [3, 5, 6, 7].iter().map(|&c| row[c].replace("**", "")).collect();
    quoted.extend(parts(&row[8]));
    let label = format!("{}, {method}, {}", row[0], row[2]);
    assert_eq!(quoted, [&figures[..4], &figures[4..6]].concat(), "{label}");
    assert_eq!(row[4], held_out_cr(&text, method), "{label}: CR held out");
    (label, text)
}

#[test]
fn the_in_traffic_protocol_table_quotes_its_outputs() {
    let doc = measured_docs();
    // CR, CR held out, SR, SR-crit, witness, VJ / AJ; each method with V_h
    // alone (the runs over 30 and the sweep's over 28) and in traffic.
    let mut checked = Vec::new();
    let header = "| set | method | feasibility | CR | CR held out | SR | SR-crit | witness | VJ / AJ |";
    for row in markdown_rows(&doc, header, "On NGSIM the lookahead over 30 behaviours in traffic") {
        let Some(method) = method_of(&row[1]) else { continue };
        let file = match (row[0].as_str(), row[2].as_str()) {
            ("WOMD interactive, n = 28", "pair") => "in-path-lookahead/sweep-n28.txt".to_owned(),
            ("NGSIM, n = 60", "pair") => "evaluate-ngsim-in-path-n60.txt".to_owned(),
            ("NGSIM, n = 60", "in traffic") => "pair-in-traffic/evaluate-ngsim-in-path-n60.txt".to_owned(),
            ("WOMD interactive, n = 28", "in traffic") => {
                "pair-in-traffic/evaluate-womd-interactive-lookahead-n28.txt".to_owned()
            }
            (set, scope) => {
                let set = set_stem(set).unwrap_or_else(|| panic!("no set {set:?}"));
                match scope {
                    "pair" => format!("in-path-lookahead/n30/evaluate-{set}.txt"),
                    "in traffic" => format!("pair-in-traffic/evaluate-{set}.txt"),
                    other => panic!("no feasibility scope {other:?}"),
                }
            }
        };
        let run = (row[2] == "in traffic").then_some("feasibility pair-in-traffic");
        checked.push(check_scope_row(&row, method, &file, run).0);
    }
    assert_eq!(checked.len(), 16, "the rows in traffic and with V_h alone: {checked:?}");
}

#[test]
fn the_in_traffic_mutation_table_quotes_its_outputs() {
    let checked = check_run_table(
        "Mutation testing in traffic",
        "The shipped NGSIM suite's method catches fewer faults in traffic",
        None,
        &[
            ("NGSIM, pair", "30", "in-path-lookahead/n30/mutants-ngsim-evasive.txt"),
            ("NGSIM, in traffic", "30", "pair-in-traffic/mutants-ngsim-evasive.txt"),
            ("NGSIM, pair", "60", "mutants-ngsim-evasive-n60.txt"),
            ("NGSIM, in traffic", "60", "pair-in-traffic/mutants-ngsim-evasive-n60.txt"),
            ("WOMD interactive, pair", "28", "in-path-lookahead/n28/mutants-womd-interactive-evasive-seed0.txt"),
            ("WOMD interactive, in traffic", "28", "pair-in-traffic/mutants-womd-interactive-evasive-n28.txt"),
        ],
    );
    assert_eq!(checked, 8, "the mutation rows in traffic and with V_h alone");
}

/// The mean stage-1 time of `method` over the prior's in an evaluation
/// output's `where the time goes` table, to one decimal.
fn stage1_over_prior(output: &str, method: &str) -> String {
    let from = output.find("\nwhere the time goes").unwrap_or_else(|| panic!("no time table in the output"));
    let stage1 = |name: &str| -> f64 {
        output[from..]
            .lines()
            .map(|l| l.split_whitespace().collect::<Vec<_>>())
            .find(|cells| cells.first() == Some(&name))
            .and_then(|cells| cells.get(1)?.parse().ok())
            .unwrap_or_else(|| panic!("no stage-1 time for {name}"))
    };
    format!("{:.1}", stage1(method) / stage1("prior"))
}

#[test]
fn the_witnessed_protocol_table_quotes_its_outputs() {
    let doc = measured_docs();
    // CR, CR held out, SR, SR-crit, witness, VJ / AJ and the stage-1 time
    // over the prior's in the same run; each method under the three scopes.
    let mut checked = Vec::new();
    let header =
        "| set | method | feasibility scope | CR | CR held out | SR | SR-crit | witness | VJ / AJ | stage 1 ×prior |";
    for row in markdown_rows(&doc, header, "Asking the witness keeps the conflicts") {
        let Some(method) = method_of(&row[1]) else { continue };
        let (set, over_28) = match row[0].split_once(", n = ") {
            Some((set, "28")) => (set, true),
            Some((_, n)) => panic!("no runs over {n} behaviours"),
            None => (row[0].as_str(), false),
        };
        let set = set_stem(set).unwrap_or_else(|| panic!("no set {set:?}"));
        let (file, run) = match (row[2].as_str(), over_28) {
            // The sweep's run has no prior row to time against.
            ("pair", true) => ("in-path-lookahead/sweep-n28.txt".to_owned(), None),
            ("pair", false) => (format!("in-path-lookahead/n30/evaluate-{set}.txt"), None),
            ("in traffic", false) => {
                (format!("pair-in-traffic/evaluate-{set}.txt"), Some("feasibility pair-in-traffic"))
            }
            ("witnessed", false) => (format!("witnessed/evaluate-{set}.txt"), Some("feasibility witnessed")),
            ("witnessed", true) => {
                (format!("witnessed/evaluate-{set}-lookahead-n28.txt"), Some("feasibility witnessed"))
            }
            (other, _) => panic!("no feasibility scope {other:?} over {}", row[0]),
        };
        let (label, text) = check_scope_row(&row, method, &file, run);
        if row[9] != "–" {
            assert_eq!(row[9], stage1_over_prior(&text, method), "{label}: stage 1 over the prior's");
        }
        checked.push(label);
    }
    assert_eq!(checked.len(), 21, "three scopes, two methods, three sets, and over 28: {checked:?}");
}

#[test]
fn the_witnessed_mutation_table_quotes_its_outputs() {
    let checked = check_run_table(
        "Mutation testing with the witness asked",
        "The witness changes only the variants whose contacts had no escape",
        None,
        &[
            ("NGSIM, pair", "30", "in-path-lookahead/n30/mutants-ngsim-evasive.txt"),
            ("NGSIM, in traffic", "30", "pair-in-traffic/mutants-ngsim-evasive.txt"),
            ("NGSIM, witnessed", "30", "witnessed/mutants-ngsim-evasive.txt"),
            ("WOMD interactive, pair", "30", "in-path-lookahead/n30/mutants-womd-interactive-evasive-seed0.txt"),
            ("WOMD interactive, witnessed", "30", "witnessed/mutants-womd-interactive-evasive.txt"),
        ],
    );
    assert_eq!(checked, 5, "the lookahead's mutation rows under the three scopes");
}

/// The stage-1 cut-ins of `method` and all its stage-1 conflicts, from an
/// output's `kinds of conflict` table.
fn stage1_cut_ins(output: &str, method: &str) -> (u32, u32) {
    let from = output.find("\nkinds of conflict").unwrap_or_else(|| panic!("no kinds table in the output"));
    let mut lines = output[from..].lines().skip(2);
    let cells: Vec<&str> = lines
        .find(|l| l.split_whitespace().next() == Some(method))
        .unwrap_or_else(|| panic!("no kinds row for {method}"))
        .split_whitespace()
        .collect();
    // Each kind is `stage1 / stage2`; cut-in is the second kind.
    let stage1: Vec<u32> = cells[1..].chunks(3).map(|k| k[0].parse().expect("a count")).collect();
    (stage1[1], stage1.iter().sum())
}

#[test]
fn the_wide_witnessed_tables_quote_their_outputs() {
    let doc = measured_docs();
    let header = "| set | method | feasibility scope | CR | CR held out | SR | SR-crit | witness | VJ / AJ | stage-1 cut-ins | stage 1 ×prior |";
    let mut checked = Vec::new();
    for row in markdown_rows(&doc, header, "over 150 behaviours meets NGSIM's goals") {
        let Some(method) = method_of(&row[1]) else { continue };
        let (file, run) = match (row[0].as_str(), row[2].as_str()) {
            ("NGSIM, n = 100", "pair") => ("cut-in/evaluate-ngsim-n100.txt", None),
            ("NGSIM, n = 100", "witnessed") => {
                ("wide-witnessed/evaluate-ngsim-n100.txt", Some("feasibility witnessed"))
            }
            ("NGSIM, n = 150", "pair") => ("wide-witnessed/evaluate-ngsim-n150-pair.txt", None),
            ("NGSIM, n = 150", "witnessed") => {
                ("wide-witnessed/evaluate-ngsim-n150.txt", Some("feasibility witnessed"))
            }
            (set, scope) => panic!("no output for {set:?} in scope {scope:?}"),
        };
        let (label, text) = check_scope_row(&row, method, file, run);
        let n = row[0].trim_start_matches("NGSIM, n = ");
        assert!(text.contains(&format!("trust region n = {n},")), "{file} is not a run over {n} behaviours");
        if run.is_none() {
            assert!(!text.contains("; feasibility"), "{file} is not a run with V_h alone");
        }
        let cut_ins = row[9].replace("**", "");
        let (c, total) = stage1_cut_ins(&text, method);
        let share = 100.0 * f64::from(c) / f64::from(total);
        assert_eq!(cut_ins, format!("{c} / {total} ({share:.1} %)"), "{label}: stage-1 cut-ins");
        assert_eq!(row[10], stage1_over_prior(&text, method), "{label}: stage 1 over the prior's");
        checked.push(label);
    }
    assert_eq!(checked.len(), 8, "two methods, two scopes, over 100 and 150: {checked:?}");

    let outputs = [
        ("NGSIM, pair", "60", "cut-in/mutants-ngsim-evasive-n60.txt"),
        ("NGSIM, witnessed", "60", "wide-witnessed/mutants-ngsim-evasive-n60.txt"),
        ("NGSIM, pair, `--seed 1000`", "60", "cut-in/mutants-ngsim-evasive-n60-seed1000.txt"),
        ("NGSIM, witnessed, `--seed 1000`", "60", "wide-witnessed/mutants-ngsim-evasive-n60-seed1000.txt"),
        ("NGSIM, pair", "100", "mutants-ngsim-evasive-n100.txt"),
        ("NGSIM, witnessed", "150", "wide-witnessed/mutants-ngsim-evasive-n150.txt"),
    ];
    let (from, to) = ("Mutation testing of the wider regions", "The wider region does not catch more faults");
    assert_eq!(check_run_table(from, to, None, &outputs), 8, "the wider regions' and the suite region's mutation rows");
    let rows = markdown_rows(&doc, from, to);
    let column = |name: &str| rows[0].iter().position(|c| c == name).unwrap_or_else(|| panic!("no {name}"));
    let (cut_in_column, no_escape_column) = (column("stage-1 cut-ins"), column("no-escape"));
    for row in &rows[1..] {
        let (_, _, file) = outputs.iter().find(|(label, n, _)| row[0] == *label && row[1] == *n).unwrap();
        let method = method_of(&row[2]).unwrap();
        let text = repo_file(&format!("docs/evaluation/{file}"));
        let witnessed = row[0].contains("witnessed");
        assert_eq!(text.contains("; feasibility witnessed"), witnessed, "{file}: the scope {}", row[0]);
        assert_eq!(file.contains("seed1000"), row[0].contains("`--seed 1000`"), "{file}: the draw of seeds");
        let (c, total) = stage1_cut_ins(&text, method);
        assert_eq!(row[cut_in_column], format!("{c} / {total}"), "{}, {method}: stage-1 cut-ins", row[0]);
        // reach, reach-crit, SR-avoid, avoid-fail, no-escape.
        let conflicts = output_table(&text, "reach-crit");
        assert_eq!(row[no_escape_column], conflicts[method][4], "{}, {method}: no-escape", row[0]);
    }
}

/// The cells after `label` (`safer-in-path (closed-loop)`: a method and its
/// stage-2 mode, as an output of several modes names its rows) in the
/// output's first table whose header line starts with `method` and holds
/// `header_word`.
fn labelled_row(output: &str, header_word: &str, label: &str) -> Vec<String> {
    let mut lines = output.lines().skip_while(|l| !(l.starts_with("method") && l.contains(header_word)));
    lines.next().unwrap_or_else(|| panic!("no table with {header_word:?} in the output"));
    let line = lines
        .take_while(|l| !l.trim().is_empty())
        .find(|l| l.strip_prefix(label).is_some_and(|rest| rest.starts_with(' ')))
        .unwrap_or_else(|| panic!("no row {label:?} in the {header_word:?} table"));
    line[label.len()..].split_whitespace().map(str::to_owned).collect()
}

/// A side-by-side table's rows, each with the set and the draw of seeds
/// (or whatever else its second column groups by, such as the planner)
/// it belongs to (a blank first or second cell continues the row above's).
fn rows_by_set_and_draw(rows: &[Vec<String>]) -> Vec<(String, String, &[String])> {
    let (mut set, mut draw) = (String::new(), String::new());
    rows.iter()
        .map(|row| {
            if !row[0].is_empty() {
                set = row[0].clone();
            }
            if !row[1].is_empty() {
                draw = row[1].clone();
            }
            (set.clone(), draw.clone(), &row[..])
        })
        .collect()
}

/// Each of `rows` with its first cell, a blank one continuing the row
/// above's (a table grouped by set or draw).
fn rows_by_first_cell(rows: &[Vec<String>]) -> Vec<(String, &[String])> {
    let mut first = String::new();
    rows.iter()
        .map(|row| {
            if !row[0].is_empty() {
                first = row[0].clone();
            }
            (first.clone(), &row[..])
        })
        .collect()
}

/// The mutation run's figures a side-by-side table quotes of the row
/// `label` of an evaluation output: SR; passed; kills (held out); ×log;
/// ×prior; scene kills; reach-crit; avoid-fail; no-escape.
fn mutation_run_figures(output: &str, label: &str) -> Vec<String> {
    let evaluation = labelled_row(output, "variants", label);
    let kills = labelled_row(output, "passed", label);
    let conflicts = labelled_row(output, "reach-crit", label);
    vec![
        evaluation[3].clone(),
        kills[0].clone(),
        format!("{} ({})", killed(&kills[1]), kills[3]),
        kills[4].clone(),
        kills[5].clone(),
        kills[6].clone(),
        conflicts[1].clone(),
        conflicts[3].clone(),
        conflicts[4].clone(),
    ]
}

/// The side-by-side mutation runs' outputs under `docs/evaluation/DIR/`:
/// (set, draw, file name).
const SIDE_BY_SIDE_OUTPUTS: [(&str, &str, &str); 4] = [
    ("WOMD interactive", "seed 0", "mutants-womd-interactive-evasive.txt"),
    ("WOMD interactive", "seed 1000", "mutants-womd-interactive-evasive-seed1000.txt"),
    ("NGSIM", "seed 0", "mutants-ngsim-evasive-n60.txt"),
    ("NGSIM", "seed 1000", "mutants-ngsim-evasive-n60-seed1000.txt"),
];

/// The output file of a side-by-side table's row of `set` and `draw`.
fn side_by_side_output(set: &str, draw: &str) -> &'static str {
    SIDE_BY_SIDE_OUTPUTS
        .iter()
        .find(|(s, d, _)| set.starts_with(s) && draw == *d)
        .map(|(_, _, file)| *file)
        .unwrap_or_else(|| panic!("no output for {set}, {draw}"))
}

#[test]
fn the_reaction_time_table_quotes_its_outputs() {
    let doc = measured_docs();
    let rows = markdown_rows(&doc, "| set | draw | stage-2 CBV |", "The delayed CBV");
    let mut checked = 0;
    for (set, draw, row) in rows_by_set_and_draw(&rows) {
        let file = format!("reaction-delay/{}", side_by_side_output(&set, &draw));
        let output = repo_file(&format!("docs/evaluation/{file}"));
        let mode = method_of(&row[2]).unwrap_or_else(|| panic!("no stage-2 mode in {row:?}"));
        let expected = mutation_run_figures(&output, &format!("safer-in-path ({mode})"));
        let cells: Vec<String> = row[3..].iter().map(|c| c.replace("**", "")).collect();
        assert_eq!(cells, expected, "{set}, {draw}, {mode}: the table against {file}");
        checked += 1;
    }
    assert_eq!(checked, 8, "two stage-2 modes for each set and draw");
}

#[test]
fn the_recorded_traffic_braking_table_quotes_its_outputs() {
    let doc = measured_docs();
    let rows = markdown_rows(&doc, "| set | draw | recorded cars |", "On NGSIM, where");
    let mut checked = 0;
    for (set, draw, row) in rows_by_set_and_draw(&rows) {
        let background = method_of(&row[2]).unwrap_or_else(|| panic!("no background in {row:?}"));
        // The replayed rows are the closed-loop runs beside the delayed CBV;
        // the reactive runs have the one stage-2 mode, unnamed in the row.
        let (dir, label) = match background {
            "log-replay" => ("reaction-delay", "safer-in-path (closed-loop)"),
            "reactive-log-replay" => ("recorded-cars-braking", "safer-in-path"),
            other => panic!("no outputs with the background {other}"),
        };
        let file = format!("{dir}/{}", side_by_side_output(&set, &draw));
        let output = repo_file(&format!("docs/evaluation/{file}"));
        // CR, the mutation run's figures, then collisions with the CBV / with others.
        let mut expected = vec![labelled_row(&output, "variants", label)[2].clone()];
        expected.extend(mutation_run_figures(&output, label));
        let collided = labelled_row(&output, "collided", label);
        expected.push(format!("{} / {}", collided[2], collided[6]));
        assert_eq!(row[3..], expected[..], "{set}, {draw}, {background}: the table against {file}");
        checked += 1;
    }
    assert_eq!(checked, 8, "two backgrounds for each set and draw");
}

#[test]
fn the_critical_variants_at_the_planner_table_quotes_its_outputs() {
    let doc = measured_docs();
    let rows = markdown_rows(&doc, "| set | draw | critical |", "On WOMD interactive many of the critical");
    let mut checked = 0;
    for (set, draw, row) in rows_by_set_and_draw(&rows) {
        let file = match draw.as_str() {
            "ten seeds" if set.starts_with("NGSIM") => "mutants-ngsim-evasive-n60-ten-seeds.txt",
            _ => side_by_side_output(&set, &draw),
        };
        let output = repo_file(&format!("docs/evaluation/recorded-cars-braking/{file}"));
        // The bands, then reach-crit from the conflicts table.
        let mut expected = labelled_row(&output, "critical", "safer-in-path");
        expected.push(labelled_row(&output, "reach-crit", "safer-in-path")[1].clone());
        assert_eq!(row[2..], expected[..], "{set}, {draw}: the table against recorded-cars-braking/{file}");
        checked += 1;
    }
    assert_eq!(checked, 5, "two draws on each set and ten seeds on NGSIM");
}

#[test]
fn the_leader_tables_quote_their_outputs() {
    let doc = measured_docs();
    // The paper's protocol with the ego's leader as the CBV.
    let rows = markdown_rows(&doc, "| CBV | method | n | CR | SR | SR-crit |", "On the NGSIM scenes with a leader");
    for row in &rows {
        let method = method_of(&row[1]).unwrap_or_else(|| panic!("no method in {row:?}"));
        let file = match row[2].as_str() {
            "20" => "leader/evaluate-ngsim.txt",
            "60" => "leader/evaluate-ngsim-n60.txt",
            n => panic!("no output for n = {n}"),
        };
        let (table, text) = evaluation_output(file);
        let figures = evaluation_figures(&table, method);
        let quoted = [&row[3..7], &parts(&row[7])[..], &[row[8].clone()][..]].concat();
        let expected = [&figures[..4], &figures[4..6], &[held_out_cr(&text, method)][..]].concat();
        assert_eq!(quoted, expected, "{method} at n = {}: the table against {file}", row[2]);
    }
    assert_eq!(rows.len(), 4, "the prior, safer and safer-in-path at 20, safer-in-path at 60");
    // The faults each pairing catches: every row names its output.
    let rows = markdown_rows(&doc, "| planner, set | CBV | output |", "With its leader as the CBV");
    for row in &rows {
        let file = method_of(&row[2]).unwrap_or_else(|| panic!("no output in {row:?}"));
        let output = repo_file(&format!("docs/evaluation/{file}"));
        let label = "safer-in-path";
        let mut expected = vec![labelled_row(&output, "variants", label)[2].clone()];
        expected.extend(mutation_run_figures(&output, label));
        assert_eq!(row[3..], expected[..], "{}, {}: the table against {file}", row[0], row[1]);
        let leader = output.contains("the CBV is the ego's leader (--roles leader)");
        assert_eq!(leader, row[1] == "leader", "{file}: its pairing");
    }
    assert_eq!(rows.len(), 8, "two pairings for each planner and set");
}

#[test]
fn the_first_contact_tables_quote_their_outputs() {
    let doc = measured_docs();
    // The paper's protocol, both losses.
    let rows = markdown_rows(&doc, "| scenes | in-path loss | n | output | CR | SR | SR-crit |", "The faults caught");
    for row in &rows {
        let file = method_of(&row[3]).unwrap_or_else(|| panic!("no output in {row:?}"));
        let (table, text) = evaluation_output(file);
        let figures = evaluation_figures(&table, "safer-in-path");
        let expected = [&figures[..6], &[held_out_cr(&text, "safer-in-path")][..]].concat();
        assert_eq!(row[4..], expected[..], "{}, n = {}: the table against {file}", row[1], row[2]);
        assert_eq!(file.starts_with("first-contact/"), row[1] == "first contact", "{file}: its loss");
    }
    assert_eq!(rows.len(), 8, "both losses, the leader at n = 20 and 60 and the own pairs on two sets");
    // The faults caught: each run with the lead steps and at the first contact.
    let rows = markdown_rows(&doc, "| planner, set | CBV | in-path loss | output |", "At the first contact");
    let mut before = None;
    for row in &rows {
        let file = method_of(&row[3]).unwrap_or_else(|| panic!("no output in {row:?}"));
        let output = repo_file(&format!("docs/evaluation/{file}"));
        let label = "safer-in-path";
        let evaluation = labelled_row(&output, "variants", label);
        let run = mutation_run_figures(&output, label);
        let expected =
            [&[evaluation[2].clone(), run[0].clone(), evaluation[6].clone(), evaluation[7].clone()][..], &run[1..]]
                .concat();
        assert_eq!(row[4..], expected[..], "{}, {}, {}: the table against {file}", row[0], row[1], row[2]);
        // Each first-contact row remakes the run above it, under first-contact/.
        match row[2].as_str() {
            "lead steps" => before = Some(file.to_owned()),
            "first contact" => {
                let before = before.take().unwrap_or_else(|| panic!("{file}: no lead-steps row above it"));
                assert_eq!(file, format!("first-contact/{before}"), "{file}: the run it remakes");
            }
            other => panic!("no in-path loss {other:?}"),
        }
    }
    assert!(rows.len() >= 16, "both losses for every remade run: {} rows", rows.len());
}

/// The suffix of an output's name for a table's `draw` cell (`seed 0`:
/// none, `seed 1000`: `-seed1000`).
fn draw_suffix(draw: &str) -> &'static str {
    match draw {
        "seed 0" => "",
        "seed 1000" => "-seed1000",
        other => panic!("no outputs of the draw {other:?}"),
    }
}

/// The set and the draw's suffix of the both-pairings outputs of a
/// table's `set` and `draw` cells (`mutants-SET-evasive-ROLES{SUFFIX}.txt`,
/// `scene-kills-SET{SUFFIX}.txt`).
fn both_pairings_names(set: &str, draw: &str) -> (&'static str, &'static str) {
    let set = match set {
        "WOMD interactive" => "womd-interactive",
        "NGSIM" => "ngsim",
        other => panic!("no both-pairings runs of {other:?}"),
    };
    (set, draw_suffix(draw))
}

/// How the docs quote a fault caught in `caught` of `of` scenes:
/// `caught/of (P %)`, P rounded to a whole percent.
fn scenes_caught(caught: u32, of: u32) -> String {
    let percent = (100.0 * f64::from(caught) / f64::from(of)).round();
    format!("{caught}/{of} ({percent} %)")
}

/// The row of `method` and `pairing` of a `scene_kills_union.py` table.
fn scene_kills_row<'t>(table: &'t str, method: &str, pairing: &str) -> &'t str {
    let prefix = format!("| `{method}` | {pairing}");
    // The pairing cell may go on with the number of scenes: `either, held out (6 scenes)`.
    table
        .lines()
        .find(|l| l.strip_prefix(&prefix).is_some_and(|rest| rest.starts_with(" |") || rest.starts_with(" (")))
        .unwrap_or_else(|| panic!("no row {prefix:?}"))
}

/// The fewest scenes any fault was caught in, of a row of a
/// `scene_kills_union.py` table: (caught, scenes with a passed variant).
fn fewest_scene_kills(table: &str, method: &str, pairing: &str) -> (u32, u32) {
    let line = scene_kills_row(table, method, pairing);
    let cells = line.trim_matches('|').split('|').map(str::trim).skip(2);
    let counts = cells.filter_map(|c| {
        let (caught, rest) = c.split_once('/')?;
        Some((caught.parse().ok()?, rest.split_whitespace().next()?.parse().ok()?))
    });
    counts.min().unwrap_or_else(|| panic!("no counts in {line:?}"))
}

#[test]
fn the_both_pairings_tables_quote_their_outputs() {
    let doc = measured_docs();
    let kills = |file: &str, label: &str| -> u32 {
        let output = repo_file(&format!("docs/evaluation/both-pairings/{file}"));
        killed(&labelled_row(&output, "passed", label)[1]).parse().unwrap()
    };
    let rows = markdown_rows(&doc, "| set | draw | kills, own pairs |", "The fault caught in the fewest");
    for (set, draw, row) in rows_by_set_and_draw(&rows) {
        let (set_name, suffix) = both_pairings_names(&set, &draw);
        let own = format!("mutants-{set_name}-evasive-as-loaded{suffix}.txt");
        let leader = format!("mutants-{set_name}-evasive-leader{suffix}.txt");
        let both = |label: &str| kills(&own, label) + kills(&leader, label);
        let (method, log, prior) = (both("safer-in-path"), both("log"), both("prior"));
        let expected = [
            kills(&own, "safer-in-path").to_string(),
            kills(&leader, "safer-in-path").to_string(),
            method.to_string(),
            log.to_string(),
            prior.to_string(),
            format!("{:.2}", f64::from(method) / f64::from(log)),
            format!("{:.2}", f64::from(method) / f64::from(prior)),
        ];
        assert_eq!(row[2..], expected[..], "{set}, {draw}: the table against {own} and {leader}");
    }
    assert_eq!(rows.len(), 4, "two sets, two draws");
    let rows = markdown_rows(&doc, "| set | draw | own pairs alone | either pairing |", "Every fault in at least");
    for (set, draw, row) in rows_by_set_and_draw(&rows) {
        let (set_name, suffix) = both_pairings_names(&set, &draw);
        let file = format!("scene-kills-{set_name}{suffix}.txt");
        let table = repo_file(&format!("docs/evaluation/both-pairings/{file}"));
        let own = format!("mutants-{set_name}-evasive-as-loaded{suffix}");
        for (cell, pairing) in [(&row[2], own.as_str()), (&row[3], "either"), (&row[4], "either, held out")] {
            let (caught, of) = fewest_scene_kills(&table, "safer-in-path", pairing);
            let quoted = scenes_caught(caught, of);
            assert!(cell.ends_with(&quoted), "{set}, {draw}, {pairing}: {cell:?} against {quoted:?} in {file}");
        }
    }
    assert_eq!(rows.len(), 4, "two sets, two draws");
}

#[test]
fn the_lane_follower_pairings_table_quotes_its_outputs() {
    let doc = measured_docs();
    let rows = markdown_rows(
        &doc,
        "| set | pairing | no-brake | weak-brake | late | blind-cbv | blind-side | no-evade | speeding |",
        "The leader adds no scene",
    );
    for (set, row) in rows_by_first_cell(&rows) {
        let (set_name, _) = both_pairings_names(&set, "seed 0");
        let file = format!("scene-kills-{set_name}.txt");
        let table = repo_file(&format!("docs/evaluation/lane-follower-pairings/{file}"));
        let pairing = match row[1].as_str() {
            "own pairs" => format!("mutants-{set_name}-lane-follower-n60-as-loaded"),
            "leader" => format!("mutants-{set_name}-lane-follower-n60-leader"),
            other => other.to_owned(),
        };
        let line = scene_kills_row(&table, "safer-in-path-lookahead", &pairing);
        let cells: Vec<&str> = line.trim_matches('|').split('|').map(str::trim).skip(2).take(7).collect();
        assert_eq!(row[2..], cells[..], "{set}, {}: the table against {file}", row[1]);
    }
    assert_eq!(rows.len(), 8, "two sets, four pairings each");
}

#[test]
fn the_lookahead_first_contact_tables_quote_their_outputs() {
    let doc = measured_docs();
    let method = "safer-in-path-lookahead";
    let rows = markdown_rows(&doc, "| n | in-path loss | CR | CR held out |", "Over 28 behaviours it meets");
    let remade: Vec<_> = rows.iter().filter(|r| r[1] == "first contact").collect();
    for row in &remade {
        let file = format!("first-contact/in-path-lookahead/evaluate-womd-interactive-n{}.txt", row[0]);
        let (table, text) = evaluation_output(&file);
        let figures = evaluation_figures(&table, method);
        let expected = [
            figures[0].clone(),
            held_out_cr(&text, method),
            figures[1].clone(),
            figures[2].clone(),
            figures[3].clone(),
            format!("{} / {}", figures[4], figures[5]),
        ];
        assert_eq!(row[2..], expected[..], "n = {}: the table against {file}", row[0]);
    }
    assert_eq!(remade.len(), 2, "n = 20 and 28 at the first contact");
    let rows =
        markdown_rows(&doc, "| draw | method | n | passed | kills (held out) |", "With the lead steps the lookahead");
    for (draw, row) in rows_by_first_cell(&rows) {
        let label = method_of(&row[1]).unwrap_or_else(|| panic!("no method in {row:?}"));
        let file = match label {
            "safer-in-path-lookahead" => format!(
                "first-contact/in-path-lookahead/mutants-womd-interactive-evasive-n28{}.txt",
                draw_suffix(&draw)
            ),
            "safer-in-path" => {
                format!("first-contact/reactive-background/{}", side_by_side_output("WOMD interactive", &draw))
            }
            other => panic!("no output for {other}"),
        };
        let run = mutation_run_figures(&repo_file(&format!("docs/evaluation/{file}")), label);
        assert_eq!(row[3..8], run[1..6], "{draw}, {label}: the table against {file}");
    }
    assert_eq!(rows.len(), 4, "two methods, two draws");
}

/// The fault the `label` row of a mutation output's kills table was
/// caught in the fewest scenes: (scenes where it was caught, scenes with a
/// passed variant), from its per-mutant `kills (caught/of)` cells.
fn fewest_fault_scenes(output: &str, label: &str) -> (u32, u32) {
    fault_scene_counts(output, label)
        .into_iter()
        .min()
        .unwrap_or_else(|| panic!("no per-mutant counts in the {label} row"))
}

/// Each fault operator's (scenes where it was killed, scenes with a passed
/// variant) in a mutation output's kills row of `label`, in the output's order.
fn fault_scene_counts(output: &str, label: &str) -> Vec<(u32, u32)> {
    let kills = labelled_row(output, "passed", label);
    kills
        .iter()
        .filter_map(|cell| {
            let (caught, of) = cell.strip_prefix('(')?.strip_suffix(')')?.split_once('/')?;
            Some((caught.parse().ok()?, of.parse().ok()?))
        })
        .collect()
}

#[test]
fn the_lookahead_first_contact_ngsim_tables_quote_their_outputs() {
    let doc = measured_docs();
    let header =
        "| n | method | feasibility scope | CR | CR held out | SR | SR-crit | witness | VJ / AJ | stage-1 cut-ins |";
    let mut checked = Vec::new();
    for row in markdown_rows(&doc, header, "The evasive planner's and the lane follower's faults on NGSIM") {
        let method = method_of(&row[1]).unwrap_or_else(|| panic!("no method in {row:?}"));
        let (file, run) = match row[2].as_str() {
            "pair" => (format!("first-contact/in-path-lookahead/evaluate-ngsim-n{}.txt", row[0]), None),
            "witnessed" => (
                format!("first-contact/in-path-lookahead/evaluate-ngsim-n{}-witnessed.txt", row[0]),
                Some("feasibility witnessed"),
            ),
            other => panic!("no feasibility scope {other:?}"),
        };
        let (label, text) = check_scope_row(&row, method, &file, run);
        assert!(text.contains(&format!("trust region n = {},", row[0])), "{file} is not a run over {}", row[0]);
        let (c, total) = stage1_cut_ins(&text, method);
        let share = 100.0 * f64::from(c) / f64::from(total);
        assert_eq!(row[9], format!("{c} / {total} ({share:.1} %)"), "{label}: stage-1 cut-ins");
        assert_eq!(row[10], stage1_over_prior(&text, method), "{label}: stage 1 over the prior's");
        checked.push(label);
    }
    assert_eq!(checked.len(), 5, "both methods over 30 and 60, the lookahead witnessed: {checked:?}");

    let header = "| draw | planner | method | feasibility scope | passed | kills (held out) |";
    let rows = markdown_rows(&doc, header, "Over 60 behaviours with the witness asked it meets");
    let mut checked = Vec::new();
    // The draw is the table's first column, the planner its second.
    for (draw, planner, row) in rows_by_set_and_draw(&rows) {
        let method = method_of(&row[2]).unwrap_or_else(|| panic!("no method in {row:?}"));
        let suffix = draw_suffix(&draw);
        let file = match (planner.as_str(), method, row[3].as_str()) {
            ("evasive", "safer-in-path-lookahead", "pair") => {
                format!("first-contact/in-path-lookahead/mutants-ngsim-evasive-n60{suffix}.txt")
            }
            ("evasive", "safer-in-path-lookahead", "witnessed") => {
                format!("first-contact/in-path-lookahead/mutants-ngsim-evasive-n60-witnessed{suffix}.txt")
            }
            ("evasive", "safer-in-path", "pair") => {
                format!("first-contact/reactive-background/{}", side_by_side_output("NGSIM", &draw))
            }
            ("lane follower", "safer-in-path-lookahead", "pair") => {
                format!("first-contact/in-path-lookahead/mutants-ngsim-lane-follower-n60{suffix}.txt")
            }
            ("lane follower", "safer-in-path", "pair") => {
                format!("first-contact/leader/mutants-ngsim-lane-follower-n60-as-loaded{suffix}.txt")
            }
            ("lane follower on WOMD interactive", "safer-in-path-lookahead", "pair") => {
                format!("first-contact/in-path-lookahead/mutants-womd-interactive-lane-follower-n60{suffix}.txt")
            }
            ("lane follower on WOMD interactive", "safer-in-path", "pair") => {
                format!("first-contact/leader/mutants-womd-interactive-lane-follower-n60-as-loaded{suffix}.txt")
            }
            other => panic!("no output for {other:?}"),
        };
        let output = repo_file(&format!("docs/evaluation/{file}"));
        assert_eq!(output.contains("; feasibility witnessed"), row[3] == "witnessed", "{file}: the scope");
        assert!(output.contains("trust region n = 60,"), "{file} is not a run over 60");
        let run = mutation_run_figures(&output, method);
        let label = format!("{draw}, {planner}, {method}, {}", row[3]);
        assert_eq!(row[4..9], run[1..6], "{label}: the table against {file}");
        let (caught, of) = fewest_fault_scenes(&output, method);
        assert!(row[9].ends_with(&scenes_caught(caught, of)), "{label}: {:?} in {file}", row[9]);
        checked.push(label);
    }
    assert_eq!(checked.len(), 9, "NGSIM's seven rows and the lane follower's two on WOMD interactive: {checked:?}");
}

#[test]
fn the_blind_twin_table_quotes_its_outputs() {
    let doc = measured_docs();
    let rows =
        markdown_rows(&doc, "| set | draw | critical | contact | under 1 m | 1–2 m", "On WOMD interactive the near");
    let mut checked = 0;
    for (set, draw, row) in rows_by_set_and_draw(&rows) {
        let file = side_by_side_output(&set, &draw);
        let output = repo_file(&format!("docs/evaluation/recorded-cars-braking/{file}"));
        // Critical, contact and under 1 m from the bands; the CBV-blind
        // twin's three cells; reach-crit; met.
        let bands = labelled_row(&output, "critical", "safer-in-path");
        let twin = labelled_row(&output, " met", "safer-in-path");
        let mut expected = bands[..3].to_vec();
        expected.extend(twin[..3].iter().cloned());
        expected.push(labelled_row(&output, "reach-crit", "safer-in-path")[1].clone());
        expected.push(twin[3].clone());
        assert_eq!(row[2..], expected[..], "{set}, {draw}: the table against recorded-cars-braking/{file}");
        checked += 1;
    }
    assert_eq!(checked, 4, "two draws on each set");
}

#[test]
fn the_ten_seed_blind_twin_table_quotes_its_outputs() {
    let doc = measured_docs();
    let rows =
        markdown_rows(&doc, "| set | method | n | CR | SR | critical | reach-crit | 1–2 m", "on WOMD interactive: met");
    let mut checked = 0;
    for row in &rows {
        let method = method_of(&row[1]).expect("a method");
        let file = match (row[0].as_str(), method) {
            ("WOMD interactive", "safer-in-path") => "womd-interactive-evasive.txt",
            ("WOMD interactive", "safer-in-path-lookahead") => "womd-interactive-evasive-lookahead-n28.txt",
            ("NGSIM", "safer-in-path") => "ngsim-evasive-n60.txt",
            other => panic!("no output for {other:?}"),
        };
        let output = repo_file(&format!("docs/evaluation/blind-twin/{file}"));
        let region = output.lines().find_map(|l| l.split("trust region n = ").nth(1)).expect("the run's region");
        let evaluation = labelled_row(&output, "variants", method);
        let conflicts = labelled_row(&output, "reach-crit", method);
        let twin = labelled_row(&output, " met", method);
        let mut expected =
            vec![region.split(',').next().unwrap().to_owned(), evaluation[2].clone(), evaluation[3].clone()];
        expected.push(labelled_row(&output, "critical", method)[0].clone());
        expected.push(conflicts[1].clone());
        // The three bands and met, then met over the held-out scenes.
        expected.extend(twin[..4].iter().cloned());
        expected.push(twin.last().expect("met over the held-out scenes").clone());
        expected.push(conflicts[4].clone());
        assert_eq!(row[2..], expected[..], "{row:?} against blind-twin/{file}");
        checked += 1;
    }
    assert_eq!(checked, 3, "two methods on WOMD interactive, one on NGSIM");
}

/// Whether an output's header line says its run kept the CBV from
/// contacts from behind the ego, as the table's `ego contact` cell must.
fn check_ego_contact(output: &str, cell: &str, file: &str) {
    check_header_rule(output, file, "; no contact from behind the ego", cell == "`not-from-behind`");
}

/// Whether the output's header line names the rule `phrase` exactly when
/// the table says the run had it (`ruled`).
fn check_header_rule(output: &str, file: &str, phrase: &str, ruled: bool) {
    let header = output.lines().find(|l| l.contains(" scenes × ")).unwrap_or_else(|| panic!("{file}: no header line"));
    assert_eq!(header.contains(phrase), ruled, "{file}: the run's header against the table ({phrase:?})");
}

#[test]
fn the_ego_contact_tables_quote_their_outputs() {
    let doc = measured_docs();
    let paper = markdown_rows(
        &doc,
        "| method | ego contact | output | CR | SR | SR-crit | witness | VJ | AJ |",
        "How the CBV touched the recorded ego in the same runs",
    );
    for row in &paper {
        let method = method_of(&row[0]).expect("a method");
        let file = row[2].trim_matches('`');
        let output = repo_file(&format!("docs/evaluation/{file}"));
        check_ego_contact(&output, &row[1], file);
        // CR, SR, SR-crit, witness, VJ, AJ.
        assert_eq!(row[3..], labelled_row(&output, "variants", method)[2..8], "{row:?} against {file}");
    }
    assert_eq!(paper.len(), 4, "two methods, each with either rule");

    // The first contacts' kinds, from the same runs.
    let contacts = markdown_rows(
        &doc,
        "| method | ego contact | critical | ego's front | side | from behind |",
        "The rule cuts the contacts from behind",
    );
    for row in &contacts {
        let method = method_of(&row[0]).expect("a method");
        let file = if row[1] == "`any`" {
            "ego-contact/evaluate-womd-interactive-n28-any.txt"
        } else {
            "ego-contact/evaluate-womd-interactive-n28.txt"
        };
        let output = repo_file(&format!("docs/evaluation/{file}"));
        check_ego_contact(&output, &row[1], file);
        assert_eq!(row[2..], labelled_row(&output, "ego's front", method)[..], "{row:?} against {file}");
    }
    assert_eq!(contacts.len(), 4, "two methods, each with either rule");

    let evasive = markdown_rows(
        &doc,
        "| set | method | n | ego contact | output | CR | SR | SR-crit | no-escape |",
        "(`met` needs the blind-twin table",
    );
    evasive.iter().for_each(|row| check_ego_contact_mutation_row(row));
    assert_eq!(evasive.len(), 14, "three rows on WOMD interactive and four on NGSIM, in each of two draws");
    let lane_follower = markdown_rows(
        &doc,
        "The lane follower's (the same settings",
        "(`met` needs the blind-twin table, which the `any` runs",
    );
    // The header, then the rows.
    lane_follower[1..].iter().for_each(|row| check_ego_contact_mutation_row(row));
    assert_eq!(lane_follower.len(), 7, "three rows on each set, under the header");

    // The n-sweep with the rule: each row its run's (n = 28 the paper-protocol run's).
    let sweep =
        markdown_rows(&doc, "| n | CR | SR | SR-crit | witness | VJ | AJ | held-out CR / SR |", "No region meets CR");
    for row in &sweep {
        let (file, output) = ego_contact_protocol_run(&row[0], "`not-from-behind`");
        let method = "safer-in-path-lookahead";
        assert_eq!(row[1..7], labelled_row(&output, "variants", method)[2..8], "{row:?} against {file}");
        let held_out = labelled_row(&output, "SR-witnessed |", method);
        assert_eq!(row[7], format!("{} / {}", held_out[0], held_out[1]), "{row:?} against {file}");
    }
    assert_eq!(sweep.len(), 5, "n = 20, 28, 40, 60 and 100");

    // CR by where the CBV starts, from the same runs: each cell its
    // output's, the scene counts of the header every run's.
    let header =
        "| n | ego contact | behind (19 scenes) | beside (1) | ahead (5) | crossing (12) | oncoming (17) | CR |";
    let by_start = markdown_rows(&doc, header, "The CR the rule gives up");
    for row in &by_start {
        let (file, output) = ego_contact_protocol_run(&row[0], &row[1]);
        let method = "safer-in-path-lookahead";
        // "0.411 (19)": the CR and the scene count of each start.
        let cells = labelled_row(&output, "oncoming", method);
        let quoted: Vec<String> =
            row[2..7].iter().zip(["19", "1", "5", "12", "17"]).map(|(cr, n)| format!("{cr} ({n})")).collect();
        assert_eq!(quoted, cells.chunks(2).map(|c| c.join(" ")).collect::<Vec<_>>(), "{row:?} against {file}");
        assert_eq!(row[7], labelled_row(&output, "variants", method)[2], "{row:?}: CR against {file}");
    }
    assert_eq!(by_start.len(), 6, "any contact over 28, and the rule's sweep");
}

/// The paper-protocol run of the lookahead on WOMD interactive over `n`
/// behaviours with the ego-contact `rule` cell (`any` over 28 only), as
/// its file and output (`default-sweep/`), checked to be over `n` and
/// under that rule.
fn ego_contact_protocol_run(n: &str, rule: &str) -> (String, String) {
    let file = match (n, rule) {
        ("28", "`any`") => "default-sweep/any-n28.txt".to_owned(),
        (n, _) => format!("default-sweep/sweep-n{n}.txt"),
    };
    let output = repo_file(&format!("docs/evaluation/{file}"));
    check_ego_contact(&output, rule, &file);
    assert!(output.contains(&format!("trust region n = {n},")), "{file}: not over {n} behaviours");
    (file, output)
}

/// A row of the ego-contact mutation tables against its output: the
/// region, the rule, CR, SR, SR-crit, no-escape, reach-crit, met, kills
/// (held out), scene kills, ×log and the faults killed in a fifth of the
/// scenes.
fn check_ego_contact_mutation_row(row: &[String]) {
    check_mutation_row(row, check_ego_contact);
}

/// [`check_ego_contact_mutation_row`] with `check_rule` judging the rule
/// cell (`row[3]`) against the output.
fn check_mutation_row(row: &[String], check_rule: fn(&str, &str, &str)) {
    let method = method_of(&row[1]).expect("a method");
    let file = row[4].trim_matches('`');
    let output = repo_file(&format!("docs/evaluation/{file}"));
    check_rule(&output, &row[3], file);
    let region = output.lines().find_map(|l| l.split("trust region n = ").nth(1)).expect("the run's region");
    let evaluation = labelled_row(&output, "variants", method);
    let conflicts = labelled_row(&output, "reach-crit", method);
    let kills = labelled_row(&output, "passed", method);
    // Has the run the blind-twin table (`met`)?
    let met = if output.lines().any(|l| l.starts_with("method") && l.contains(" met")) {
        labelled_row(&output, " met", method)[3].clone()
    } else {
        "—".to_owned()
    };
    // The fault operators killed in at least a fifth of the scenes:
    // each operator's `(scenes killed/scenes with a passed variant)`.
    let per_fault: Vec<(usize, usize)> = kills[13..]
        .iter()
        .filter_map(|c| c.strip_prefix('(')?.strip_suffix(')')?.split_once('/'))
        .map(|(k, n)| (k.parse().unwrap(), n.parse().unwrap()))
        .collect();
    let in_a_fifth = per_fault.iter().filter(|(k, n)| 5 * k >= *n).count();
    let expected = vec![
        region.split(|c: char| !c.is_ascii_digit()).next().unwrap().to_owned(),
        row[3].clone(),
        row[4].clone(),
        evaluation[2].clone(),
        evaluation[3].clone(),
        evaluation[4].clone(),
        conflicts[4].clone(),
        conflicts[1].clone(),
        met,
        format!("{} ({})", killed(&kills[1]), killed(&kills[3])),
        kills[6].clone(),
        kills[4].clone(),
        format!("{in_a_fifth}/{}", per_fault.len()),
    ];
    assert_eq!(row[2..], expected[..], "{row:?} against {file}");
}

/// Whether an output's header line says its run kept the CBV from driving
/// against the traffic, as the table's `wrong way rule` cell must.
fn check_wrong_way(output: &str, cell: &str, file: &str) {
    check_header_rule(output, file, "; no driving against the traffic", cell == "`forbidden`");
}

#[test]
fn the_wrong_way_tables_quote_their_outputs() {
    let doc = measured_docs();
    let shares = markdown_rows(
        &doc,
        "| set | method | wrong way rule | output | CR | SR | SR-crit | wrong way | wrong way s2 | across lanes | across s2 |",
        "The evasive planner's mutation tables with the rule",
    );
    for row in &shares {
        let method = method_of(&row[1]).expect("a method");
        let file = row[3].trim_matches('`');
        let output = repo_file(&format!("docs/evaluation/{file}"));
        check_wrong_way(&output, &row[2], file);
        // CR, SR, SR-crit; then the two wrong-way and the two across-lanes
        // shares of the plausibility table.
        assert_eq!(row[4..7], labelled_row(&output, "variants", method)[2..5], "{row:?} against {file}");
        let plausibility = labelled_row(&output, "wrong way", method);
        assert_eq!(row[7..9], plausibility[5..7], "{row:?} against {file}");
        assert_eq!(row[9..11], plausibility[9..11], "{row:?} against {file}");
    }
    assert_eq!(shares.len(), 14, "the recorded CBV and three methods with either rule, on two sets");

    let mutation = markdown_rows(
        &doc,
        "| set | method | n | wrong way rule | output | CR | SR | SR-crit | no-escape |",
        "What they say",
    );
    // The rows with the rule and without, each checked against its output.
    for row in &mutation {
        check_mutation_row(row, |output, cell, file| {
            check_wrong_way(output, cell, file);
            check_header_rule(output, file, "; no contact from behind the ego", true);
        });
    }
    assert_eq!(mutation.len(), 8, "the lookahead with either rule, on two sets, in each of two draws");
}

#[test]
fn the_no_evade_paths_table_quotes_its_outputs() {
    let doc = measured_docs();
    let rows = markdown_rows(
        &doc,
        "| planner | set | pairing | `no-evade` off the path | farthest (m) | `no-evade` kills (scenes) |",
        "So the lane follower's",
    );
    // A blank planner or set cell continues the row above's.
    for (planner, set, row) in rows_by_set_and_draw(&rows) {
        let (set_name, _) = both_pairings_names(&set, "seed 0");
        let file = match (planner.as_str(), row[2].as_str()) {
            ("lane follower", "own pairs") => {
                format!("lane-follower-pairings/mutants-{set_name}-lane-follower-n60-as-loaded.txt")
            }
            ("lane follower", "leader") => {
                format!("lane-follower-pairings/mutants-{set_name}-lane-follower-n60-leader.txt")
            }
            ("evasive", "own pairs") => {
                let n = if set_name == "ngsim" { 60 } else { 28 };
                format!("ego-contact/mutants-{set_name}-evasive-n{n}.txt")
            }
            other => panic!("no output for {other:?}"),
        };
        let output = repo_file(&format!("docs/evaluation/{file}"));
        let method = "safer-in-path-lookahead";
        // The mutants' paths table: (off the path, farthest) per mutant; no-evade is the sixth.
        let paths_table = output.split("mutants' paths").nth(1).unwrap_or_else(|| panic!("no paths table in {file}"));
        let paths = labelled_row(paths_table, "no-brake", method);
        // The kills table ends with each mutant's `kills (scenes)`; no-evade is the last but one.
        let kills = labelled_row(&output, "passed", method);
        let no_evade_kills = format!("{} {}", kills[kills.len() - 4], kills[kills.len() - 3]);
        assert_eq!(
            row[3..],
            [paths[10].clone(), paths[11].clone(), no_evade_kills],
            "{planner}, {set}, {}: against {file}",
            row[2]
        );
    }
    assert_eq!(rows.len(), 6, "the lane follower with both pairings on two sets, the evasive planner on two");
}

/// The set and trust region of a row of the lookahead tables with no
/// contact from behind: `NGSIM (n = 60)` or `WOMD interactive (n = 28)`.
fn lookahead_set(set: &str) -> (&'static str, u32) {
    match set {
        "NGSIM (n = 60)" => ("ngsim", 60),
        "WOMD interactive (n = 28)" => ("womd-interactive", 28),
        other => panic!("no output for the set {other:?}"),
    }
}

/// The mutation output of `planner` under the lookahead with no contact
/// from behind, the CBV driving any way: the default planner's in
/// `ego-contact/`, the at-fault planner's in `at-fault-planner/`.
fn any_way_output(planner: &str, set_name: &str, n: u32) -> String {
    match planner {
        "evasive" => format!("ego-contact/mutants-{set_name}-evasive-n{n}.txt"),
        "evasive-at-fault" => format!("at-fault-planner/mutants-{set_name}-n{n}.txt"),
        other => panic!("no output for the planner {other:?}"),
    }
}

#[test]
fn the_at_fault_planner_table_quotes_its_outputs() {
    let doc = measured_docs();
    let rows = markdown_rows(
        &doc,
        "| set | planner | method | SR | passed | kills | held out | ×log | ×prior | scene kills |",
        "- The planner that avoids only what it is blamed for",
    );
    // A blank set or planner cell continues the row above's.
    for (set, planner, row) in rows_by_set_and_draw(&rows) {
        let (set_name, n) = lookahead_set(&set);
        let file = any_way_output(&planner, set_name, n);
        let output = repo_file(&format!("docs/evaluation/{file}"));
        let method = method_of(&row[2]).unwrap_or_else(|| panic!("no method in {:?}", row[2]));
        // The evaluation table: variants, errors, CR, SR, ...
        let sr = labelled_row(&output, "SR-crit", method)[3].clone();
        // The kills table: passed, kills, |, held out, ×log, ×prior, scene kills, ...
        let kills = labelled_row(&output, "passed", method);
        let quoted = [sr, kills[0].clone(), kills[1].clone(), kills[3].clone(), kills[4].clone(), kills[5].clone()];
        assert_eq!(row[3..9], quoted, "{set}, {planner}, {method}: against {file}");
        assert_eq!(row[9], kills[6], "{set}, {planner}, {method}: scene kills against {file}");
    }
    assert_eq!(rows.len(), 6, "two methods with each planner on NGSIM, the lookahead with each on WOMD interactive");
}

#[test]
fn the_along_the_lanes_table_quotes_its_outputs() {
    let doc = measured_docs();
    let rows = markdown_rows(
        &doc,
        "| set | planner | CBV | CR | SR-crit | reach-crit | wrong way s2 | across s2 | passed | kills | held out |",
        "- **Realism.**",
    );
    let method = "safer-in-path-lookahead";
    // A blank set or planner cell continues the row above's.
    for (set, planner, row) in rows_by_set_and_draw(&rows) {
        let (set_name, n) = lookahead_set(&set);
        let file = match (planner.as_str(), row[2].as_str()) {
            (planner, "any way") => any_way_output(planner, set_name, n),
            ("evasive", "along the lanes") => format!("along-the-lanes/mutants-{set_name}-n{n}-evasive.txt"),
            ("evasive-at-fault", "along the lanes") => format!("along-the-lanes/mutants-{set_name}-n{n}-at-fault.txt"),
            other => panic!("no output for {other:?}"),
        };
        let output = repo_file(&format!("docs/evaluation/{file}"));
        // The evaluation table (variants, errors, CR, SR, SR-crit, ...), the
        // reach table (reach, reach-crit, ...), the plausibility table
        // (wrong way s2 the 7th value, across s2 the 11th) and the kills
        // table (passed, kills, |, held out, ×log, ×prior, scene kills, ...).
        let evaluation = labelled_row(&output, "SR-crit", method);
        let reach = labelled_row(&output, "reach-crit", method);
        let plausibility = labelled_row(&output, "across s2", method);
        let kills = labelled_row(&output, "passed", method);
        let quoted = [
            &evaluation[2],
            &evaluation[4],
            &reach[1],
            &plausibility[6],
            &plausibility[10],
            &kills[0],
            &kills[1],
            &kills[3],
            &kills[4],
            &kills[5],
            &kills[6],
        ];
        let cells: Vec<&String> = row[3..].iter().collect();
        assert_eq!(cells, quoted, "{set}, {planner}, {}: against {file}", row[2]);
    }
    assert_eq!(rows.len(), 8, "each planner with the CBV either way on two sets");

    // The lane follower's rows, each against its output.
    let lane_follower = markdown_rows(&doc, "The Python lane follower, over 60 behaviours", "- **As many of the");
    // The header, then the rows.
    for row in &lane_follower[1..] {
        check_mutation_row(row, |output, cell, file| {
            check_header_rule(
                output,
                file,
                "; no driving against the traffic or across the lanes",
                cell == "`along-the-lanes`",
            );
            check_header_rule(output, file, "; no contact from behind the ego", true);
            check_header_rule(output, file, "stage 2 planner `lane-follower`", true);
        });
    }
    assert_eq!(lane_follower.len(), 5, "the CBV either way on two sets, under the header");
}

#[test]
fn the_sideways_speed_table_quotes_its_outputs() {
    let doc = measured_docs();
    let rows = markdown_rows(
        &doc,
        "| set | method | output | CR | measured | p50 | p90 | max | recorded p50 | recorded p90 | recorded max |",
        "Most recorded CBVs keep their lane",
    );
    for row in &rows {
        let method = method_of(&row[1]).expect("a method");
        let file = row[2].trim_matches('`');
        let output = repo_file(&format!("docs/evaluation/{file}"));
        check_header_rule(&output, file, "; no driving against the traffic or across the lanes", true);
        assert_eq!(row[3], labelled_row(&output, "variants", method)[2], "CR: {row:?} against {file}");
        // measured, p50, p90, max | recorded measured, p50, p90, max.
        let sideways = labelled_row(&output, "measured", method);
        assert_eq!(row[4..8], sideways[0..4], "{row:?} against {file}");
        assert_eq!(row[8..11], sideways[6..9], "{row:?} against {file}");
    }
    assert_eq!(rows.len(), 10, "five methods on two sets");
}

#[test]
fn the_resampled_kill_ratio_table_quotes_its_outputs() {
    let doc = measured_docs();
    let rows = markdown_rows(
        &doc,
        "| set | planner | method | output | kills (held out) | ×log | ×log over resampled scenes | ×prior | ×prior over resampled scenes |",
        "The mutation goals hold beyond",
    );
    for row in &rows {
        let method = method_of(&row[2]).expect("a method");
        let file = row[3].trim_matches('`');
        let output = repo_file(&format!("docs/evaluation/{file}"));
        // passed, kills | held out, ×log, ×prior, ...
        let kills = labelled_row(&output, "passed", method);
        let ranges = labelled_row(&output, "95 %", method);
        let quoted = [format!("{} ({})", killed(&kills[1]), kills[3]), kills[4].clone(), ranges[0].clone()];
        assert_eq!(row[4..7], quoted[..], "{row:?} against {file}");
        assert_eq!(row[7..9], [kills[5].clone(), ranges[1].clone()], "{row:?} against {file}");
    }
    assert_eq!(rows.len(), 8, "two methods, two planners, two sets");
}

#[test]
fn the_lane_change_table_quotes_its_outputs() {
    let doc = measured_docs();
    let rows = markdown_rows(
        &doc,
        "| set | method | output | changed | p50 | p90 | max | recorded | recorded p50 | recorded p90 | recorded max | held out changed | p50 | p90 | held out recorded | p50 | p90 |",
        "What they show",
    );
    for row in &rows {
        let method = method_of(&row[1]).expect("a method");
        let file = row[2].trim_matches('`');
        let output = repo_file(&format!("docs/evaluation/{file}"));
        // changed, p50, p90, max | recorded, p50, p90, max | held out:
        // changed, p50, p90 | recorded, p50, p90.
        let cells: Vec<String> = labelled_row(&output, "changed", method).into_iter().filter(|c| c != "|").collect();
        assert_eq!(row[3..], cells[..], "{row:?} against {file}");
    }
    assert_eq!(rows.len(), 10, "five methods on two sets");
}

#[test]
fn the_human_lane_change_pace_table_quotes_its_outputs() {
    let doc = measured_docs();
    let rows = markdown_rows(
        &doc,
        "| set | planner | rule | output | CR | SR-crit | CBV at fault / off road | lane changes | p50 | p90 | max | recorded p50 / p90 | kills (held out) | ×log | ×log over resampled scenes | ×prior | ×prior over resampled scenes |",
        "What the rule does",
    );
    let method = "safer-in-path-lookahead";
    for row in &rows {
        let file = row[3].trim_matches('`');
        let output = repo_file(&format!("docs/evaluation/{file}"));
        // variants, errors, CR, SR, SR-crit, ...
        let main = labelled_row(&output, "SR-crit", method);
        // CBV-bg coll, CBV at fault, of it: ped/cyc, CBV off-road, ...
        let plausibility = labelled_row(&output, "CBV at fault", method);
        // changed, p50, p90, max | recorded, p50, p90, max | ...
        let lane_changes: Vec<String> =
            labelled_row(&output, "changed", method).into_iter().filter(|c| c != "|").collect();
        let kills = labelled_row(&output, "passed", method);
        let ranges = labelled_row(&output, "95 %", method);
        let quoted = [
            main[2].clone(),
            main[4].clone(),
            format!("{} / {}", plausibility[1], plausibility[3]),
            lane_changes[0].clone(),
            lane_changes[1].clone(),
            lane_changes[2].clone(),
            lane_changes[3].clone(),
            format!("{} / {}", lane_changes[5], lane_changes[6]),
            format!("{} ({})", killed(&kills[1]), kills[3]),
            kills[4].clone(),
            ranges[0].clone(),
            kills[5].clone(),
            ranges[1].clone(),
        ];
        assert_eq!(row[4..], quoted[..], "{row:?} against {file}");
        let rule_dir = if row[2] == "`along-the-lanes`" { "kill-ratios/" } else { "human-lane-changes/" };
        assert!(file.starts_with(rule_dir), "{row:?}: the rule and the output disagree");
    }
    assert_eq!(rows.len(), 8, "two rules, two planners, two sets");
}

/// `before → after`, as the side-by-side tables quote a figure.
fn arrow(before: &str, after: &str) -> String {
    format!("{before} → {after}")
}

/// The output of a run under the shipped lookahead suite's settings for
/// the set and planner a side-by-side table names (`kill-ratios/`,
/// `grip/` and `turning/` name theirs alike).
fn suite_settings_output(set: &str, planner: &str) -> &'static str {
    match (set, planner) {
        ("NGSIM", "evasive") => "mutants-ngsim-n60-evasive.txt",
        ("WOMD interactive", "evasive") => "mutants-womd-interactive-n28-evasive.txt",
        ("NGSIM", "lane follower") => "mutants-ngsim-lane-follower-n60.txt",
        ("WOMD interactive", "lane follower") => "mutants-womd-interactive-lane-follower-n60.txt",
        other => panic!("no output for {other:?}"),
    }
}

/// A method's kills in a mutation output as the side-by-side tables quote
/// them: `kills (held out)`, `×log (its 95 % range)`, `×prior (its range)`.
fn kill_cells(output: &str, method: &str) -> [String; 3] {
    // passed, kills | held out, ×log, ×prior, ...
    let kills = labelled_row(output, "passed", method);
    let ranges = labelled_row(output, "95 %", method);
    [
        format!("{} ({})", killed(&kills[1]), kills[3]),
        format!("{} ({})", kills[4], ranges[0]),
        format!("{} ({})", kills[5], ranges[1]),
    ]
}

#[test]
fn the_grip_tables_quote_their_outputs() {
    let doc = measured_docs();
    // The paper's protocol: the "with" side's every cell, the "without"
    // side's from the outputs made before the rule (which lack the
    // beyond-grip column).
    let rows = markdown_rows(
        &doc,
        "| method | n | ego contact | output without | output with | beyond grip (without → with) |",
        "The shipped lookahead suite's settings",
    );
    for row in &rows {
        let method = method_of(&row[0]).unwrap();
        let output = |cell: &str| repo_file(&format!("docs/evaluation/{}", cell.trim_matches('`')));
        let (without, with) = (output(&row[3]), output(&row[4]));
        let (before, after) = (labelled_row(&without, "SR-crit", method), labelled_row(&with, "SR-crit", method));
        let grip = labelled_row(&with, "beyond grip", method);
        let figures = |cells: &[String]| format!("{} / {} / {}", cells[6], cells[7], cells[8]);
        let beyond_before = row[5].split(" → ").next().unwrap().to_owned();
        let quoted = [
            arrow(&beyond_before, grip.last().unwrap()),
            arrow(&before[2], &after[2]),
            arrow(&before[3], &after[3]),
            arrow(&before[4], &after[4]),
            arrow(&figures(&before), &figures(&after)),
        ];
        assert_eq!(row[5..], quoted[..], "{row:?}");
        assert_eq!(grip.last().unwrap(), "0.000", "{row:?}: a CBV beyond grip with the rule");
    }
    assert_eq!(rows.len(), 3);
    // The shipped lookahead suite's settings: kill-ratios/ without, grip/ with.
    let rows = markdown_rows(
        &doc,
        "| set | planner | n | beyond grip (without → with) | CR | SR-crit |",
        "No CBV turns beyond grip, at little cost",
    );
    let method = "safer-in-path-lookahead";
    for row in &rows {
        let file = suite_settings_output(&row[0], &row[1]);
        let figures = |dir: &str| {
            let output = repo_file(&format!("docs/evaluation/{dir}/{file}"));
            let main = labelled_row(&output, "SR-crit", method);
            let reach = labelled_row(&output, "reach-crit", method);
            [main[2].clone(), main[4].clone(), main[5].clone(), reach[1].clone()]
                .into_iter()
                .chain(kill_cells(&output, method))
                .collect::<Vec<_>>()
        };
        let (before, after) = (figures("kill-ratios"), figures("grip"));
        let quoted: Vec<String> = before.iter().zip(&after).map(|(b, a)| arrow(b, a)).collect();
        assert_eq!(row[4..], quoted[..], "{row:?}");
        let grip = labelled_row(&repo_file(&format!("docs/evaluation/grip/{file}")), "beyond grip", method);
        assert_eq!(row[3].split(" → ").nth(1), grip.last().map(String::as_str), "{row:?}");
    }
    assert_eq!(rows.len(), 4, "two sets, two planners");
}

#[test]
fn the_turning_limit_tables_quote_their_outputs() {
    let limit = TurningTables {
        dir: "turning",
        paper: (
            "| method | n | ego contact | CR (grip → 4 m/s²) |",
            "The shipped lookahead suite's settings, the evasive planner",
        ),
        suite: ("| set | planner | n | CR (grip → 4 m/s²) | SR-crit |", "Held to turning at most 4 m/s²"),
        peak_at_most_mps2: Some(4.0),
    };
    limit.quote_their_outputs();
}

#[test]
fn the_turning_cost_tables_quote_their_outputs() {
    let cost = TurningTables {
        dir: "turning-cost",
        paper: (
            "| method | n | ego contact | CR (none → 0.1) |",
            "The shipped lookahead suite's settings, the evasive planner",
        ),
        suite: ("| set | planner | n | CR (none → 0.1) | SR-crit |", "With a turn costing 0.1 m per m/s²"),
        peak_at_most_mps2: None,
    };
    cost.quote_their_outputs();
}

#[test]
fn the_turning_cost_sweep_quotes_its_outputs() {
    let doc = measured_docs();
    let rows = markdown_rows(&doc, "| cost (m per m/s²) | CR |", "It stays opt-in: on NGSIM");
    let method = "safer-in-path-lookahead";
    let costs: Vec<&str> = rows.iter().map(|r| r[0].as_str()).collect();
    assert_eq!(costs, ["none", "0.05", "0.1", "0.25", "0.5", "1"]);
    for row in &rows {
        // The paper's protocol, then the suite's settings on WOMD interactive and on NGSIM.
        let names = [
            "evaluate-womd-interactive-lookahead-n28",
            "mutants-womd-interactive-n28-evasive",
            "mutants-ngsim-n60-evasive",
        ];
        let [paper, womd, ngsim] = names.map(|name| {
            repo_file(&match row[0].as_str() {
                "none" => format!("docs/evaluation/grip/{name}.txt"),
                "0.1" => format!("docs/evaluation/turning-cost/{name}.txt"),
                cost => format!("docs/evaluation/turning-cost/sweep/{name}-c{cost}.txt"),
            })
        });
        let main = labelled_row(&paper, "SR-crit", method);
        let lateral = paper.split("\nlateral acceleration of the CBV").nth(1).expect("the lateral acceleration table");
        let peaks = labelled_row(lateral, "measured", method);
        let mut quoted =
            vec![main[2].clone(), main[4].clone(), main[8].clone(), format!("{} / {}", peaks[1], peaks[2])];
        for output in [&womd, &ngsim] {
            let main = labelled_row(output, "SR-crit", method);
            let kills = labelled_row(output, "passed", method);
            quoted.extend([main[2].clone(), main[4].clone(), format!("{} ({})", killed(&kills[1]), kills[3])]);
        }
        assert_eq!(row[1..], quoted[..], "{row:?}");
    }
}

/// A section of `benchmarks.md` that sets the CBV's turning under a rule
/// (the outputs under `docs/evaluation/{dir}/`) beside the same runs held
/// within grip alone (`grip/`): the paper's protocol on WOMD interactive
/// and the shipped lookahead suite's settings, each table from the first
/// line starting with its header to its end marker.
struct TurningTables {
    dir: &'static str,
    paper: (&'static str, &'static str),
    suite: (&'static str, &'static str),
    /// The most the rule lets a peak be, m/s² (a limit; a cost has none).
    peak_at_most_mps2: Option<f64>,
}

impl TurningTables {
    fn quote_their_outputs(&self) {
        let doc = measured_docs();
        // A method's peak lateral accelerations in an output: p50, p90, max.
        let peaks = |output: &str, method: &str| {
            let table =
                output.split("\nlateral acceleration of the CBV").nth(1).expect("the lateral acceleration table");
            labelled_row(table, "measured", method)[1..4].to_vec()
        };
        // The paper's protocol: grip/ against the rule's, every cell.
        let rows = markdown_rows(&doc, self.paper.0, self.paper.1);
        for row in &rows {
            let method = method_of(&row[0]).unwrap();
            let file = if method == "safer-in-path-lookahead" {
                "evaluate-womd-interactive-lookahead-n28.txt"
            } else {
                "evaluate-womd-interactive.txt"
            };
            let (grip, ruled) = (
                repo_file(&format!("docs/evaluation/grip/{file}")),
                repo_file(&format!("docs/evaluation/{}/{file}", self.dir)),
            );
            let (before, after) = (labelled_row(&grip, "SR-crit", method), labelled_row(&ruled, "SR-crit", method));
            let figures = |cells: &[String]| format!("{} / {} / {}", cells[6], cells[7], cells[8]);
            let quoted = [
                arrow(&before[2], &after[2]),
                arrow(&before[3], &after[3]),
                arrow(&before[4], &after[4]),
                arrow(&figures(&before), &figures(&after)),
                arrow(&peaks(&grip, method).join(" / "), &peaks(&ruled, method).join(" / ")),
            ];
            assert_eq!(row[3..], quoted[..], "{row:?}");
            if let Some(limit) = self.peak_at_most_mps2 {
                let within = peaks(&ruled, method).iter().all(|p| p.parse::<f64>().unwrap() <= limit);
                assert!(within, "{row:?}: beyond the limit");
            }
        }
        assert_eq!(rows.len(), 3);
        // The shipped lookahead suite's settings, both planners.
        let rows = markdown_rows(&doc, self.suite.0, self.suite.1);
        let method = "safer-in-path-lookahead";
        for row in &rows {
            let file = suite_settings_output(&row[0], &row[1]);
            let figures = |dir: &str| {
                let output = repo_file(&format!("docs/evaluation/{dir}/{file}"));
                let main = labelled_row(&output, "SR-crit", method);
                let reach = labelled_row(&output, "reach-crit", method);
                let plausibility = labelled_row(&output, "CBV off-road", method);
                let p = peaks(&output, method);
                [main[2].clone(), main[4].clone(), reach[1].clone()]
                    .into_iter()
                    .chain(kill_cells(&output, method))
                    .chain([format!("{} / {}", p[0], p[1]), plausibility[3].clone()])
                    .collect::<Vec<_>>()
            };
            let (before, after) = (figures("grip"), figures(self.dir));
            let quoted: Vec<String> = before.iter().zip(&after).map(|(b, a)| arrow(b, a)).collect();
            assert_eq!(row[3..], quoted[..], "{row:?}");
        }
        assert_eq!(rows.len(), 4, "two sets, two planners");
    }
}

/// The fault operator killed in the smallest share of the scenes with a
/// passed variant, in a mutation output's kills row of `label`:
/// `NAME k/of (P %)` (the first such operator in the output's order).
fn fewest_scenes_cell(output: &str, label: &str) -> String {
    let header = output.lines().find(|l| l.starts_with("method") && l.contains("passed")).expect("a mutation table");
    let counts = fault_scene_counts(output, label);
    // The header ends with the operators' names, one a count.
    let words: Vec<&str> = header.split_whitespace().collect();
    let names = &words[words.len().saturating_sub(counts.len())..];
    assert_eq!(names.len(), counts.len(), "{label}: a name per operator");
    // The smallest share, compared exactly (a/b < c/d as a·d < c·b).
    let (name, (caught, of)) = names
        .iter()
        .zip(counts)
        .reduce(|best, next| {
            if u64::from(next.1.0) * u64::from(best.1.1) < u64::from(best.1.0) * u64::from(next.1.1) {
                next
            } else {
                best
            }
        })
        .expect("an operator");
    format!("{name} {caught}/{of} ({:.0} %)", 100.0 * f64::from(caught) / f64::from(of))
}

/// A mutation run of the shipped lookahead suite's settings as the tables
/// of those runs quote it: CR, SR-crit, reach-crit, met, kills (held
/// out), ×log, ×prior, the fault caught in the fewest scenes; `–` for the
/// ratios of a run of the lookahead alone.
fn suite_settings_cells(output: &str, method: &str, lookahead_alone: bool) -> Vec<String> {
    let main = labelled_row(output, "SR-crit", method);
    let reach = labelled_row(output, "reach-crit", method);
    let twin = labelled_row(output, " met", method);
    let mut cells = vec![main[2].clone(), main[4].clone(), reach[1].clone(), twin[3].clone()];
    if lookahead_alone {
        let kills = labelled_row(output, "passed", method);
        cells.extend([format!("{} ({})", killed(&kills[1]), kills[3]), "–".into(), "–".into()]);
    } else {
        cells.extend(kill_cells(output, method));
    }
    cells.push(fewest_scenes_cell(output, method));
    cells
}

/// The lookahead's cells of a before → after table of the shipped
/// lookahead suite's settings ([`suite_settings_cells`], each `before →
/// after`): the output `file` of the folders `dirs` (before, after),
/// each checked to be a run over `seeds` seeds a scene.
fn suite_settings_before_after(file: &str, seeds: &str, dirs: (&str, &str), lookahead_alone: bool) -> Vec<String> {
    let cells = |dir: &str| {
        let output = repo_file(&format!("docs/evaluation/{dir}/{file}"));
        let header = output.lines().find(|l| l.contains(" scenes × ")).expect("the run's header");
        assert!(header.contains(&format!("× {seeds} seeds")), "{dir}/{file} is {header}");
        suite_settings_cells(&output, "safer-in-path-lookahead", lookahead_alone)
    };
    cells(dirs.0).iter().zip(cells(dirs.1)).map(|(b, a)| arrow(b, &a)).collect()
}

#[test]
fn the_cut_in_anticipation_table_quotes_its_outputs() {
    let doc = measured_docs();
    let rows = markdown_rows(
        &doc,
        "| set | seeds | CR | SR-crit | reach-crit | met | kills (held out) |",
        "The lane follower's faults after the change",
    );
    check_lane_follower_before_after(&rows, ("grip", "cut-in-anticipation"), "ten-seeds/lookahead");
}

/// A side-by-side table of the lane follower's mutation runs under the
/// lookahead suite's settings, rows `set | seeds | ...` over three and ten
/// seeds on both sets: each row's cells against the runs in `dirs` (before,
/// after) for three seeds, and `ten_before` and `AFTER/ten-seeds` for ten
/// (the lookahead alone).
fn check_lane_follower_before_after(rows: &[Vec<String>], dirs: (&str, &str), ten_before: &str) {
    let ten_after = format!("{}/ten-seeds", dirs.1);
    let mut checked = Vec::new();
    for (set, seeds, row) in rows_by_set_and_draw(rows) {
        let run_dirs = match seeds.as_str() {
            "3" => dirs,
            "10" => (ten_before, ten_after.as_str()),
            other => panic!("{row:?}: no output for {other} seeds"),
        };
        let file = suite_settings_output(&set, "lane follower");
        assert_eq!(row[2..], suite_settings_before_after(file, &seeds, run_dirs, seeds == "10")[..], "{row:?}");
        checked.push((set, seeds));
    }
    assert_eq!(checked.len(), 4, "two sets, each over 3 and 10 seeds: {checked:?}");
}

#[test]
fn the_standing_berth_table_quotes_its_outputs() {
    let doc = measured_docs();
    let rows = markdown_rows(
        &doc,
        "| set | CR | SR-crit | reach-crit | met | kills (held out) |",
        "The evasive planner's faults are caught as before",
    );
    let mut sets = Vec::new();
    for row in &rows {
        let file = suite_settings_output(&row[0], "evasive");
        let quoted = suite_settings_before_after(file, "10", ("ten-seeds/lookahead", "standing-berth"), false);
        assert_eq!(row[1..], quoted[..], "{row:?}");
        sets.push(row[0].clone());
    }
    assert_eq!(sets, ["WOMD interactive", "NGSIM"], "both sets, over ten seeds");
}

#[test]
fn the_ten_seed_lookahead_table_quotes_its_outputs() {
    let doc = measured_docs();
    let rows = markdown_rows(
        &doc,
        "| set | planner | n | seeds | CR | SR-crit | reach-crit | met |",
        "Every fault of the evasive planner is caught",
    );
    let method = "safer-in-path-lookahead";
    let mut n = String::new();
    let mut seeds_checked = Vec::new();
    // A blank set, planner or n cell continues the row above's.
    for (set, planner, row) in rows_by_set_and_draw(&rows) {
        if !row[2].is_empty() {
            n.clone_from(&row[2]);
        }
        let dir = match row[3].as_str() {
            "3" => "grip",
            "10" => "ten-seeds/lookahead",
            other => panic!("{row:?}: no output for {other} seeds"),
        };
        let file = suite_settings_output(&set, &planner);
        let output = repo_file(&format!("docs/evaluation/{dir}/{file}"));
        let header = output.lines().find(|l| l.contains(" scenes × ")).expect("the run's header");
        assert!(header.contains(&format!("× {} seeds", row[3])), "{row:?}: {dir}/{file} is {header}");
        assert!(header.contains(&format!("trust region n = {n},")), "{row:?}: {dir}/{file} is {header}");
        let expected = suite_settings_cells(&output, method, row[9] == "–");
        assert_eq!(row[4..], expected[..], "{row:?} against {dir}/{file}");
        seeds_checked.push(row[3].clone());
    }
    assert_eq!(seeds_checked, ["3", "10"].repeat(4), "two sets, two planners, each over 3 and 10 seeds");
}

#[test]
fn the_turning_circle_tables_quote_their_outputs() {
    let doc = measured_docs();
    // The paper's protocol: turning-circle/without/ (the build before the
    // bound) against turning-circle/, the same commands.
    let rows = markdown_rows(
        &doc,
        "| set | method | n | ego contact | tighter turn (without → with) |",
        "The shipped lookahead suite's settings over ten seeds",
    );
    let mut checked = Vec::new();
    // A blank set cell continues the row above's; the method is never blank.
    for (set, method, row) in rows_by_set_and_draw(&rows) {
        let method = method_of(&method).unwrap();
        let file = match (set.as_str(), method) {
            ("WOMD interactive", "safer-in-path-lookahead") => "evaluate-womd-interactive-lookahead-n28.txt",
            ("WOMD interactive", _) => "evaluate-womd-interactive.txt",
            ("NGSIM", _) => "evaluate-ngsim.txt",
            other => panic!("{other:?}: no output"),
        };
        let cells = |dir: &str| {
            let output = repo_file(&format!("docs/evaluation/{dir}/{file}"));
            let main = labelled_row(&output, "SR-crit", method);
            let plausibility = labelled_row(&output, "tighter turn", method);
            [
                plausibility[12].clone(),
                main[2].clone(),
                main[3].clone(),
                main[4].clone(),
                main[5].clone(),
                format!("{} / {} / {}", main[6], main[7], main[8]),
                plausibility[3].clone(),
            ]
        };
        let (before, after) = (cells("turning-circle/without"), cells("turning-circle"));
        let quoted: Vec<String> = before.iter().zip(&after).map(|(b, a)| arrow(b, a)).collect();
        assert_eq!(row[4..], quoted[..], "{row:?}");
        if method != "log" {
            assert_eq!(after[0], "0.000", "{row:?}: a CBV tighter than a car with the bound");
        }
        checked.push((set, method.to_owned()));
    }
    assert_eq!(checked.len(), 7, "four rows on WOMD interactive, three on NGSIM: {checked:?}");
    // The shipped lookahead suite's settings over ten seeds, the evasive
    // planner: standing-berth/ (the build before the bound) against
    // turning-circle/.
    let rows =
        markdown_rows(&doc, "| set, ten seeds | CR | SR-crit | reach-crit | met | kills (held out) |", "Kills fall by");
    let mut sets = Vec::new();
    for row in &rows {
        let file = suite_settings_output(&row[0], "evasive");
        let quoted = suite_settings_before_after(file, "10", ("standing-berth", "turning-circle"), false);
        assert_eq!(row[1..], quoted[..], "{row:?}");
        sets.push(row[0].clone());
    }
    assert_eq!(sets, ["WOMD interactive", "NGSIM"], "both sets, over ten seeds");
    // The lane follower under the same settings: cut-in-anticipation/ (the
    // build before the bound) against turning-circle/.
    let rows = markdown_rows(
        &doc,
        "| set, lane follower | seeds | CR | SR-crit | reach-crit | met | kills (held out) |",
        "The lane follower's faults with the bound",
    );
    check_lane_follower_before_after(&rows, ("cut-in-anticipation", "turning-circle"), "cut-in-anticipation/ten-seeds");
}

/// The output `file` of `docs/evaluation/`, checked to be a run over
/// `seeds` seeds a scene.
fn output_over_seeds(file: &str, seeds: &str) -> String {
    let output = repo_file(&format!("docs/evaluation/{file}"));
    let header = output.lines().find(|l| l.contains(" scenes × ")).expect("the run's header");
    assert!(header.contains(&format!(" scenes × {seeds} seeds")), "{file} is {header}");
    output
}

/// [`kill_cells`] as the README's kill tables quote them: the held-out
/// kills without their variants.
fn readme_kill_cells(output: &str, method: &str) -> Vec<String> {
    let mut cells = kill_cells(output, method).to_vec();
    let kills = labelled_row(output, "passed", method);
    cells[0] = format!("{} ({})", killed(&kills[1]), killed(&kills[3]));
    cells
}

/// The fault caught in the fewest scenes as the README's kill tables quote
/// it: `` `weak-brake` 15 of 53 (28 %) ``.
fn readme_fewest_scenes(output: &str, method: &str) -> String {
    let cell = fewest_scenes_cell(output, method);
    let (name, rest) = cell.split_once(' ').expect("a fault and its scenes");
    format!("`{name}` {}", rest.replacen('/', " of ", 1))
}

#[test]
fn the_readme_kill_tables_quote_their_outputs() {
    let readme = repo_file("README.md");
    let method = "safer-in-path-lookahead";
    // The evasive planner, ten seeds: kills (held out), ×log, ×prior, the
    // fault caught in the fewest scenes.
    let rows = markdown_rows(
        &readme,
        "| set | kills (held out) | × log replay's | × the prior's | fewest scenes a fault is caught in |",
        "With the Python lane follower",
    );
    let mut sets = Vec::new();
    for row in &rows {
        let file = match row[0].as_str() {
            "WOMD interactive" => "bumper/mutants-womd-interactive-n28-evasive.txt",
            "NGSIM" => "bumper/mutants-ngsim-n60-evasive.txt",
            "WOMD JSON" => "womd-json-suites/mutants-womd-json-n28-evasive.txt",
            other => panic!("{other}: no output"),
        };
        let output = output_over_seeds(file, "10");
        let mut quoted = readme_kill_cells(&output, method);
        quoted.push(readme_fewest_scenes(&output, method));
        assert_eq!(row[1..], quoted[..], "{row:?}");
        sets.push(row[0].clone());
    }
    assert_eq!(sets, ["WOMD interactive", "NGSIM", "WOMD JSON"], "the three shared sets");
    // The lane follower: the kills over three seeds; the fault caught in
    // the fewest scenes over ten (the lookahead alone).
    let rows = markdown_rows(
        &readme,
        "| set | kills, three seeds (held out) | × log replay's | × the prior's | fewest scenes a fault is caught in, ten seeds |",
        "caught in under the fifth of the scenes",
    );
    let mut sets = Vec::new();
    for row in &rows {
        let (dir, file) = match row[0].as_str() {
            "WOMD interactive" | "NGSIM" => ("bumper", suite_settings_output(&row[0], "lane follower")),
            "WOMD JSON" => ("womd-json-suites", "mutants-womd-json-lane-follower-n60.txt"),
            other => panic!("{other}: no output"),
        };
        let three = output_over_seeds(&format!("{dir}/{file}"), "3");
        let fewest = output_over_seeds(&format!("{dir}/ten-seeds/{file}"), "10");
        assert_eq!(row[1..4], readme_kill_cells(&three, method)[..], "{row:?}");
        let weakest = readme_fewest_scenes(&fewest, method);
        assert!(row[4].starts_with(&weakest), "{row:?}: the fewest scenes are {weakest}");
        sets.push(row[0].clone());
    }
    assert_eq!(sets, ["WOMD interactive", "NGSIM", "WOMD JSON"], "the three shared sets");
}

#[test]
fn the_womd_json_suite_settings_table_quotes_its_outputs() {
    let doc = measured_docs();
    let rows = markdown_rows(
        &doc,
        "| planner | seeds | CR | SR-crit | reach-crit | met | kills (held out) | ×log (95 %) | ×prior (95 %) | fewest scenes |",
        "The kill goals hold on the third set",
    );
    let mut planners = Vec::new();
    for row in &rows {
        // The lane follower's ten-seed run is the lookahead's alone.
        let file = match (row[0].as_str(), row[1].as_str()) {
            ("evasive", "10") => "mutants-womd-json-n28-evasive.txt",
            ("lane follower", "3") => "mutants-womd-json-lane-follower-n60.txt",
            ("lane follower", "10") => "ten-seeds/mutants-womd-json-lane-follower-n60.txt",
            other => panic!("{other:?}: no output"),
        };
        let output = output_over_seeds(&format!("womd-json-suites/{file}"), &row[1]);
        let quoted = suite_settings_cells(&output, "safer-in-path-lookahead", file.starts_with("ten-seeds/"));
        assert_eq!(row[2..], quoted[..], "{row:?}");
        planners.push(format!("{} {}", row[0], row[1]));
    }
    assert_eq!(planners, ["evasive 10", "lane follower 3", "lane follower 10"], "both planners");
}

#[test]
fn the_suites_method_kill_table_quotes_its_outputs() {
    let doc = repo_file("docs/benchmarks.md");
    let rows = markdown_rows(
        &doc,
        "| set | planner | seeds | CR | SR-crit | reach-crit | met | kills (held out) | ×log (95 % of resamples) |",
        "Against log replay",
    );
    let mut runs = Vec::new();
    for row in &rows {
        let dir = if row[0] == "WOMD JSON" { "womd-json-suites" } else { "bumper" };
        let file = match (row[0].as_str(), row[1].as_str()) {
            ("WOMD JSON", "evasive") => "mutants-womd-json-n28-evasive.txt".to_owned(),
            ("WOMD JSON", "lane follower") => "mutants-womd-json-lane-follower-n60.txt".to_owned(),
            (set, planner) => suite_settings_output(set, planner).to_owned(),
        };
        // Over ten seeds the lane follower's run is the lookahead's alone.
        let alone = row[1] == "lane follower" && row[2] == "10";
        let path = if alone { format!("{dir}/ten-seeds/{file}") } else { format!("{dir}/{file}") };
        let output = output_over_seeds(&path, &row[2]);
        assert_eq!(row[3..], suite_settings_cells(&output, "safer-in-path-lookahead", alone)[..], "{row:?}");
        runs.push(format!("{} {} {}", row[0], row[1], row[2]));
    }
    assert_eq!(runs.len(), 9, "three sets, the evasive planner over ten seeds, the lane follower over three and ten");
}

#[test]
fn the_replay_against_closed_loop_table_quotes_its_outputs() {
    let doc = repo_file("docs/benchmarks.md");
    let rows = markdown_rows(
        &doc,
        "| set | planner | method | stage-2 CBV | reach | reach-crit | SR-avoid | failures |",
        "Closed loop brings more of the critical conflicts",
    );
    let mut checked = Vec::new();
    for (set, planner, row) in rows_by_set_and_draw(&rows) {
        let Some(method) = method_of(&row[2]) else { continue };
        let stem = set_stem(&set).unwrap_or_else(|| panic!("{set}: no set"));
        // Replay: the main tables' runs; closed loop: the mutation runs.
        let file = match (row[3].as_str(), planner.as_str()) {
            ("replay", "evasive") => format!("evaluate-{stem}.txt"),
            ("closed loop", "evasive") => format!("mutants/mutants-{stem}-evasive.txt"),
            ("closed loop", "lane follower") => format!("mutants/mutants-{stem}-lane-follower.txt"),
            other => panic!("{other:?}: no output"),
        };
        let output = repo_file(&format!("docs/evaluation/{file}"));
        // reach, reach-crit, SR-avoid, avoid-fail, no-escape, refuted, failures.
        let conflicts = labelled_row(&output, "reach-crit", method);
        let variants = &output_table(&output, "variants")[method][0];
        let quoted = [&conflicts[0], &conflicts[1], &conflicts[2], &format!("{} of {variants}", conflicts[6])]
            .map(|c| c.replace('—', "–"));
        assert_eq!(row[4..8], quoted[..], "{set}, {planner}, {method}, {}", row[3]);
        checked.push(format!("{set} {planner} {method} {}", row[3]));
    }
    assert_eq!(checked.len(), 20, "{checked:?}");
}

#[test]
fn the_held_out_reach_by_chance_table_quotes_its_outputs() {
    let doc = measured_docs();
    let rows = markdown_rows(
        &doc,
        "| set | reach-crit | held out | by chance | met | met, held out |",
        "the held-out 0.200 lies inside",
    );
    let method = "safer-in-path-lookahead";
    let mut sets = Vec::new();
    for row in &rows {
        let output = output_over_seeds(&format!("bumper/{}", suite_settings_output(&row[0], "evasive")), "10");
        // reach, reach-crit, ... failures, `|`, held out: reach, reach-crit,
        // SR-avoid, `|`, reach-crit by chance.
        let reach = labelled_row(&output, "reach-crit", method);
        // The twin's three bands, met, `|`, met held out.
        let twin = labelled_row(&output, " met", method);
        let quoted = [&reach[1], &reach[9], &reach[12], &twin[3], &twin[5]];
        assert_eq!(row[1..], quoted.map(String::as_str)[..], "{row:?}");
        sets.push(row[0].clone());
    }
    assert_eq!(sets, ["WOMD interactive", "NGSIM"], "both sets");
}

#[test]
fn the_bumper_ten_seed_lane_follower_table_quotes_its_outputs() {
    let doc = measured_docs();
    let rows = markdown_rows(
        &doc,
        "| set, ten seeds | reach-crit | met | kills (held out) | fewest scenes |",
        "The CBV tailgates a quarter as often",
    );
    let mut sets = Vec::new();
    for row in &rows {
        let file = suite_settings_output(&row[0], "lane follower");
        // CR, SR-crit, reach-crit, met, kills, –, –, fewest scenes.
        let cells = suite_settings_before_after(file, "10", ("turning-circle/ten-seeds", "bumper/ten-seeds"), true);
        let quoted = [&cells[2], &cells[3], &cells[4], &cells[7]];
        assert_eq!(row[1..], quoted.map(String::as_str)[..], "{row:?}");
        sets.push(row[0].clone());
    }
    assert_eq!(sets, ["WOMD interactive", "NGSIM"], "both sets");
}

/// The row under `method`'s in an output's stage-1 contacts table: its
/// critical variants not reached in stage 2, in all and by first contact.
fn not_reached_cells(output: &str, method: &str) -> Vec<String> {
    let mut lines = output.lines().skip_while(|l| !l.starts_with("how the CBV touched the recorded ego (stage 1"));
    let row = lines
        .find(|l| l.strip_prefix(method).is_some_and(|rest| rest.starts_with(' ')))
        .unwrap_or_else(|| panic!("no {method} row in the contacts table"));
    let under = lines.next().unwrap_or_default();
    let cells =
        under.strip_prefix("  of them not reached").unwrap_or_else(|| panic!("no row not reached under {row:?}"));
    cells.split_whitespace().map(str::to_owned).collect()
}

#[test]
fn the_not_reached_by_contact_table_quotes_its_outputs() {
    let doc = measured_docs();
    let rows = markdown_rows(
        &doc,
        "| set | critical | not reached | ego's front | side | from behind | ego standing | CBV standing |",
        "Of the conflicts reach-crit misses",
    );
    let method = "safer-in-path-lookahead";
    let mut sets = Vec::new();
    for row in &rows {
        let file = match row[0].as_str() {
            "WOMD interactive" => format!("bumper/{}", suite_settings_output(&row[0], "evasive")),
            "WOMD JSON" => "womd-json-suites/mutants-womd-json-n28-evasive.txt".to_owned(),
            other => panic!("{other}: no output"),
        };
        let output = output_over_seeds(&file, "10");
        let critical = labelled_row(&output, "ego's front", method)[0].clone();
        let quoted: Vec<String> = std::iter::once(critical).chain(not_reached_cells(&output, method)).collect();
        assert_eq!(row[1..], quoted[..], "{row:?} against {file}");
        sets.push(row[0].clone());
    }
    assert_eq!(sets, ["WOMD interactive", "WOMD JSON"], "the two sets reach-crit misses 0.8 on");
}

/// `method`'s row of an output's `kinds of conflict` table: each kind's
/// `stage1 / stage2` counts, in the table's order (rear-end, cut-in,
/// merge, crossing, left turn across path, head-on, sideswipe, other).
fn kinds_row(output: &str, method: &str) -> Vec<(u32, u32)> {
    let from = output.find("\nkinds of conflict").unwrap_or_else(|| panic!("no kinds table in the output"));
    let cells: Vec<&str> = output[from..]
        .lines()
        .skip(2)
        .find(|l| l.split_whitespace().next() == Some(method))
        .unwrap_or_else(|| panic!("no kinds row for {method}"))
        .split_whitespace()
        .collect();
    cells[1..].chunks(3).map(|k| (k[0].parse().expect("a count"), k[2].parse().expect("a count"))).collect()
}

/// The name outputs give the set a table names (`WOMD interactive`:
/// `womd-interactive`), `None` for a cell that names no set.
fn set_stem(set: &str) -> Option<&'static str> {
    match set {
        "WOMD interactive" => Some("womd-interactive"),
        "WOMD JSON" => Some("womd-json"),
        "NGSIM" => Some("ngsim"),
        _ => None,
    }
}

/// `dir`'s `evaluate-*.txt` output of the set a table names.
fn evaluate_output_of_set(dir: &str, set: &str) -> String {
    let stem = set_stem(set).unwrap_or_else(|| panic!("{set}: no output"));
    format!("{dir}/evaluate-{stem}.txt")
}

/// A roles table's VJ / AJ cell of a method (`–` for log replay, whose
/// CBV is the recording).
fn realism_cell(figures: &[String], method: &str) -> String {
    if method == "log" { "–".to_owned() } else { format!("{} / {}", figures[4], figures[5]) }
}

/// A method's conflicts by kind as a roles table quotes them (`stage 1 /
/// stage 2`, in the output's order of kinds), and all of them summed.
fn conflict_cells(text: &str, method: &str) -> (Vec<String>, String) {
    let kinds = kinds_row(text, method);
    let all = kinds.iter().fold((0, 0), |(a, b), &(x, y)| (a + x, b + y));
    let pair = |(a, b): (u32, u32)| format!("{a} / {b}");
    (kinds.into_iter().map(pair).collect(), pair(all))
}

#[test]
fn the_crossings_table_quotes_its_outputs() {
    let doc = measured_docs();
    let header = "| set | scenes with a crossing pair | method | CR | SR | SR-crit | VJ / AJ | crossing | left turn across path | head-on | all conflicts |";
    let mut checked = Vec::new();
    for (set, row) in
        rows_by_first_cell(&markdown_rows(&doc, header, "A CBV across the ego's way makes junction conflicts"))
    {
        let file = evaluate_output_of_set("crossing", &set);
        let (rows, text) = evaluation_output(&file);
        if !row[1].is_empty() {
            let (kept, of) = row[1].split_once(" of ").expect("K of N");
            assert!(text.contains(&format!("--roles crossing: {kept} of {of} scenes have a crossing pair")), "{row:?}");
        }
        let method = method_of(&row[2]).expect("a method");
        let figures = evaluation_figures(&rows, method);
        assert_eq!(row[3..6], figures[..3], "{set} {method}: CR, SR, SR-crit");
        assert_eq!(row[6], realism_cell(&figures, method), "{set} {method}: VJ / AJ");
        let (kinds, all) = conflict_cells(&text, method);
        assert_eq!(row[7..11], [&kinds[3][..], &kinds[4], &kinds[5], &all], "{set} {method}: conflicts");
        checked.push(format!("{set} {method}"));
    }
    assert_eq!(checked.len(), 9, "{checked:?}");
}

#[test]
fn the_merges_table_quotes_its_outputs() {
    let doc = repo_file("docs/benchmarks.md");
    let header = "| set | scenes with a merging pair | method | CR | SR | VJ / AJ | merges | all conflicts |";
    let mut checked = Vec::new();
    for (set, row) in rows_by_first_cell(&markdown_rows(&doc, header, "No stage-1 merge is made on any set")) {
        // NGSIM has no merging pair: the command says so and writes no table.
        let Some(method) = method_of(&row[2]) else { continue };
        let (rows, text) = evaluation_output(&evaluate_output_of_set("merging", &set));
        if !row[1].is_empty() {
            let (kept, of) = row[1].split_once(" of ").expect("K of N");
            assert!(text.contains(&format!("--roles merging: {kept} of {of} scenes have a merging pair")), "{row:?}");
        }
        let figures = evaluation_figures(&rows, method);
        assert_eq!(row[3..5], figures[..2], "{set} {method}: CR, SR");
        assert_eq!(row[5], realism_cell(&figures, method), "{set} {method}: VJ / AJ");
        let (kinds, all) = conflict_cells(&text, method);
        assert_eq!(row[6..8], [&kinds[2][..], &all], "{set} {method}: merges, all conflicts");
        checked.push(format!("{set} {method}"));
    }
    assert_eq!(checked.len(), 12, "{checked:?}");
}

#[test]
fn the_closest_approach_table_quotes_its_outputs() {
    let doc = measured_docs();
    let header = "| set | method | contact (CR) | no contact, gap < 0.5 m | 0.5–1 m | ≥ 1 m |";
    let mut checked = Vec::new();
    for (set, row) in rows_by_first_cell(&markdown_rows(&doc, header, "Why `safer`'s CR stays")) {
        let file = evaluate_output_of_set("closest-approach", &set);
        let output = repo_file(&format!("docs/evaluation/{file}"));
        let method = method_of(&row[1]).expect("a method");
        let bands = output_table(&output, "no contact <0.5m");
        let cells = bands.get(method).unwrap_or_else(|| panic!("no {method} row in {file}"));
        assert_eq!(row[2..6], cells[..4], "{set} {method}");
        checked.push(format!("{set} {method}"));
    }
    assert_eq!(checked.len(), 18, "six methods on each of the three sets: {checked:?}");
}

/// `kinds` as the kinds tables quote them: `stage1 / stage2` per kind.
fn kinds_cells(kinds: &[(u32, u32)]) -> Vec<String> {
    kinds.iter().map(|(a, b)| format!("{a} / {b}")).collect()
}

#[test]
fn the_kinds_tables_quote_their_outputs() {
    let doc = measured_docs();
    // Per method: the README's results run (and its run of the suites' method).
    let header =
        "| method | rear-end | cut-in | merge | crossing | left turn across path | head-on | sideswipe | other |";
    let mut methods = Vec::new();
    for row in markdown_rows(&doc, header, "SaFeR makes 2.4×") {
        let method = method_of(&row[0]).expect("a method");
        let file = if row[0].contains("the suites' method") {
            "readme-results/evaluate-womd-interactive-default.txt"
        } else {
            "readme-results/evaluate-womd-interactive.txt"
        };
        let kinds = kinds_row(&repo_file(&format!("docs/evaluation/{file}")), method);
        assert_eq!(row[1..], kinds_cells(&kinds)[..], "{}", row[0]);
        methods.push(method.to_owned());
    }
    assert_eq!(methods.len(), 8, "{methods:?}");
    // The suites' method under the suites' settings, on each set.
    let header = "| set | rear-end | cut-in | merge | crossing | left turn across path | head-on | sideswipe | cut-ins and merges of stage 1 |";
    let mut sets = Vec::new();
    for row in markdown_rows(&doc, header, "No stage-1 merge appears") {
        let file = match row[0].as_str() {
            "WOMD JSON" => "womd-json-suites/mutants-womd-json-n28-evasive.txt".to_owned(),
            set => format!("bumper/{}", suite_settings_output(set, "evasive")),
        };
        let kinds = kinds_row(&output_over_seeds(&file, "10"), "safer-in-path-lookahead");
        let mut quoted = kinds_cells(&kinds[..7]);
        let stage1: u32 = kinds.iter().map(|k| k.0).sum();
        let cut_ins_merges = kinds[1].0 + kinds[2].0;
        quoted.push(format!(
            "{cut_ins_merges} of {stage1} ({:.1} %)",
            100.0 * f64::from(cut_ins_merges) / f64::from(stage1)
        ));
        assert_eq!(row[1..], quoted[..], "{}", row[0]);
        sets.push(row[0].clone());
    }
    assert_eq!(sets, ["WOMD interactive", "NGSIM", "WOMD JSON"]);
}

/// A fault's `caught/of` cell of a `scene_kills_union.py` row.
fn union_cell(table: &str, method: &str, pairing: &str, fault: usize) -> (u32, u32) {
    let line = scene_kills_row(table, method, pairing);
    let cell = line.trim_matches('|').split('|').map(str::trim).nth(2 + fault).expect("a fault's cell");
    let (caught, rest) = cell.split_once('/').expect("caught/of");
    (caught.parse().expect("a count"), rest.split_whitespace().next().and_then(|n| n.parse().ok()).expect("a count"))
}

#[test]
fn the_junction_pairings_bullet_quotes_its_outputs() {
    let doc = measured_docs();
    let bullet: String = doc
        .lines()
        .skip_while(|l| !l.contains("Listed with both pairings, junction scenes catch more"))
        .take_while(|l| !l.starts_with("- These runs ask for the pairing"))
        .map(str::trim)
        .collect::<Vec<_>>()
        .join(" ");
    let union = repo_file("docs/evaluation/crossing/scene-kills-womd-json-lane-follower.txt");
    let whole = output_over_seeds("womd-json-suites/ten-seeds/mutants-womd-json-lane-follower-n60.txt", "10");
    let method = "safer-in-path-lookahead";
    let whole_row = labelled_row(&whole, "passed", method);
    // The per-fault cells `kills (caught/of)` are the last seven.
    let whole_caught: Vec<(u32, u32)> = whole_row[whole_row.len() - 14..]
        .chunks(2)
        .map(|c| {
            let (caught, of) = c[1].trim_matches(|ch| ch == '(' || ch == ')').split_once('/').expect("(k/n)");
            (caught.parse().unwrap(), of.parse().unwrap())
        })
        .collect();
    let own_of = |fault| union_cell(&union, method, "mutants-womd-json-lane-follower-n60-as-loaded", fault);
    let crossing_of = |fault| union_cell(&union, method, "mutants-womd-json-lane-follower-n60-crossing", fault);
    for fault in 0..7 {
        let (own, crossing) = (own_of(fault), crossing_of(fault));
        assert!(crossing.0 > own.0, "fault {fault}: the crossing CBV catches it in more scenes");
        assert_eq!(
            union_cell(&union, method, "either", fault),
            crossing,
            "fault {fault}: and wherever the own CBV does"
        );
    }
    let mut alone_counts = Vec::new();
    let mut together_counts = Vec::new();
    for (fault, name) in [(4, "blind-side"), (5, "no-evade"), (6, "speeding")] {
        let (own, crossing) = (own_of(fault), crossing_of(fault));
        let quoted = format!("`{name}` in {} against {}", crossing.0, own.0);
        assert!(bullet.contains(&quoted), "{quoted:?} in {bullet:?}");
        let (alone, of) = whole_caught[fault];
        assert_eq!(of, 63, "{name}");
        let together = alone + crossing.0 - own.0;
        let share = (100.0 * f64::from(together) / f64::from(of)).round();
        let at = bullet
            .find(&format!("`{name}` is caught in {together}"))
            .or_else(|| bullet.find(&format!("`{name}` in {together}")));
        let after = &bullet[at.unwrap_or_else(|| panic!("{name}: {together} in {bullet:?}"))..];
        assert!(
            after.contains(&format!("{together} scenes ({share} %)"))
                || after.contains(&format!("{together} ({share} %)")),
            "{name}: {share} % in {after:?}"
        );
        alone_counts.push(alone.to_string());
        together_counts.push(together);
    }
    // The README's sentence on it.
    let readme = repo_file("README.md").split_whitespace().collect::<Vec<_>>().join(" ");
    let [blind_side, no_evade, speeding] = together_counts[..] else { unreachable!() };
    let sentence = format!("({blind_side} and {speeding} of 63), `no-evade` still not ({no_evade};");
    assert!(readme.contains(&sentence), "the README: {sentence:?}");
    assert!(
        bullet.contains(&format!("in {}, {} and {}:", alone_counts[0], alone_counts[1], alone_counts[2])),
        "{alone_counts:?} in {bullet:?}"
    );
}

/// The Markdown rows of `doc` between the lines holding `from` and `to`,
/// each as its line, less the separators and the rows that start with
/// `header` (the section must hold one).
fn quoted_rows<'a>(doc: &'a str, from: &str, to: &str, header: &str) -> Vec<&'a str> {
    let section = section(doc, from, to);
    assert!(section.iter().any(|l| l.starts_with(header)), "no table {header:?} from {from:?} to {to:?}");
    section.into_iter().filter(|l| l.starts_with('|') && !l.starts_with("| ---") && !l.starts_with(header)).collect()
}

#[test]
fn the_shipped_suites_tables_quote_their_outputs() {
    let doc = repo_file("docs/benchmarks.md");
    // `mutation_tables.sh` prints each row as the benchmarks quote it.
    let printed = |file: &str| -> Vec<String> {
        repo_file(&format!("docs/evaluation/shipped-suites/{file}")).lines().map(str::to_owned).collect()
    };
    let (mutation, cost) = (printed("mutation-tables.txt"), printed("cost.txt"));
    let from = "### The shipped suites";
    let rows = quoted_rows(&doc, from, "`faults` kills every operator", "| suite | planner | method |");
    let (costs, rows): (Vec<&str>, Vec<&str>) =
        rows.into_iter().filter(|r| !r.starts_with("| suite |")).partition(|r| r.ends_with("| 8 |"));
    for row in &rows {
        assert!(mutation.iter().any(|l| l == row), "not in shipped-suites/mutation-tables.txt: {row}");
    }
    let printed_rows = mutation.iter().filter(|l| l.starts_with("| ") && l.contains(" | `")).count();
    assert_eq!(rows.len(), printed_rows, "every suite and method the script printed is quoted");
    assert_eq!(costs.len(), 5, "the cost of five suites: {costs:?}");
    for row in &costs {
        assert!(cost.iter().any(|l| l == row), "not in shipped-suites/cost.txt: {row}");
    }
}

/// A `safer run` output's conflict coverage: kind → `stage 1 / met /
/// failures`, for each suite in the output (in order).
fn conflict_coverage(output: &str) -> Vec<BTreeMap<String, String>> {
    let mut suites = Vec::new();
    let mut lines = output.lines();
    while lines.by_ref().any(|l| l.trim_start().starts_with("conflict coverage")) {
        let mut kinds = BTreeMap::new();
        for line in lines.by_ref() {
            let cells: Vec<&str> = line.split_whitespace().collect();
            let [kind, stage1, met, failures, _sr] = cells[..] else { break };
            if stage1.parse::<u32>().is_err() {
                break;
            }
            kinds.insert(kind.to_owned(), format!("{stage1} / {met} / {failures}"));
        }
        suites.push(kinds);
    }
    suites
}

#[test]
fn the_per_suite_kinds_table_quotes_its_outputs() {
    let doc = repo_file("docs/benchmarks.md");
    let rows = markdown_rows(&doc, "**Per suite** (`safer run SUITE --no-shrink`", "The shipped NGSIM suite's stage-1");
    let header = &rows[0];
    let kinds = ["rear-end", "cut-in", "crossing", "left-turn-across-path", "head-on", "sideswipe"];
    assert_eq!(&header[2..], ["rear-end", "cut-in", "crossing", "left turn across path", "head-on", "sideswipe"]);
    for row in &rows[1..] {
        let path = method_of(&row[0]).unwrap_or_else(|| panic!("no suite file in {:?}", row[0]));
        let stem = path.rsplit('/').next().unwrap().trim_end_matches(".yaml");
        let output = repo_file(&format!("docs/evaluation/shipped-suites/run-{stem}.txt"));
        let coverage = conflict_coverage(&output);
        assert_eq!(coverage.len(), 1, "{stem}: one suite's coverage");
        let variants = output.lines().find_map(|l| l.trim().strip_prefix("metrics over ")?.split(' ').next());
        assert_eq!(Some(row[1].as_str()), variants, "{stem}: variants");
        for (kind, cell) in kinds.iter().zip(&row[2..]) {
            let printed = coverage[0].get(*kind).map_or("–", String::as_str);
            assert_eq!(cell, printed, "{stem}, {kind}: stage 1 / met / failures");
        }
        assert!(coverage[0].keys().all(|k| kinds.contains(&k.as_str())), "{stem}: a kind the table leaves out");
    }
    assert_eq!(rows.len(), 4, "three suites");
}

/// An output's row of the table of whom the planner's ego hit: `method`
/// → its cells (variants, collided, scenes, most in one, ...). The
/// variants named under a row come between the rows, so each row is
/// found by its method's name.
fn stage2_contacts_row(output: &str, method: &str) -> Vec<String> {
    let table: Vec<&str> = output.lines().skip_while(|l| !l.starts_with("whom the planner's ego hit")).collect();
    let line = table
        .iter()
        .find(|l| l.split_whitespace().next() == Some(method))
        .unwrap_or_else(|| panic!("no row {method} in the table of whom the planner's ego hit"));
    line.split_whitespace().skip(1).map(str::to_owned).collect()
}

#[test]
fn the_closed_loop_failures_table_quotes_its_outputs() {
    let doc = repo_file("docs/benchmarks.md");
    let rows = markdown_rows(&doc, "### Failures beyond log replay's", "The suites' method finds");
    let sets = [("WOMD interactive", "womd-interactive"), ("WOMD JSON", "womd-json"), ("NGSIM", "ngsim")];
    let mut set = "";
    let mut safer_beyond = 0.0;
    for row in &rows[1..] {
        if !row[0].is_empty() {
            set = sets.iter().find(|(name, _)| row[0].starts_with(name)).unwrap_or_else(|| panic!("{row:?}")).1;
        }
        let method = method_of(&row[1]).unwrap();
        let run = if method == "safer" { "safer" } else { "suites" };
        let output = repo_file(&format!("docs/evaluation/closed-loop-failures/evaluate-{set}-{run}.txt"));
        let at = format!("{set}, {method}");
        let figures = output_table(&output, "variants");
        assert_eq!(row[2..4], figures[method][2..4], "{at}: CR, SR");
        let contacts = stage2_contacts_row(&output, method);
        let log = stage2_contacts_row(&output, "log");
        assert_eq!(row[4], contacts[1], "{at}: collided");
        assert_eq!(row[5], log[1], "{at}: log replay's");
        let beyond: u32 = contacts[1].parse::<u32>().unwrap() - log[1].parse::<u32>().unwrap();
        assert_eq!(row[6], beyond.to_string(), "{at}: beyond log");
        assert_eq!(row[7..9], contacts[2..4], "{at}: scenes, most in one");
        if method == "safer" {
            safer_beyond = f64::from(beyond);
        }
        assert_eq!(row[9], format!("{:.2}", f64::from(beyond) / safer_beyond), "{at}: ×safer");
        let held_out = output_table(&output, "SR-witnessed |");
        let sr = &held_out[method];
        // CR, SR, witness, SR-witnessed | CR, SR, ...
        assert_eq!(row[10], format!("{} / {}", sr[1], sr[6]), "{at}: SR held out / rest");
    }
    assert_eq!(rows.len(), 7, "two methods on three sets");
}
