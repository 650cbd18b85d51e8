#!/usr/bin/env bash
# Rewrites the tables in this folder that the shipped models make (the
# commands are the ones docs/evaluation/README.md lists), from the release
# build of this checkout. Each table ends with the run's wall time.
#
# usage: docs/evaluation/regenerate.sh [JOB...]
#   JOB   one or more of the names below (default: all of them, in order)
#
#   evaluate          evaluate-{womd-interactive,womd-json,ngsim}.txt (every method
#                     but no-mda: a method's variants do not depend on the
#                     other rows, and this way each prior's tables can be
#                     made without the other)
#   plain             what the plain-attention prior (the no-mda ablation) makes:
#                     evaluate-*-no-mda.txt, realism-prior-plain-womd16.txt,
#                     prior-fit/shipped-plain-*.txt
#   inattentive       evaluate-*-inattentive.txt
#   held-out-chance   held-out-chance-*.txt
#   trust-region      trust-region-*.txt (safer, safer-distinct, no-mda; and safer-inattentive)
#   realism           realism-prior-*.txt
#   prior-fit         prior-fit/shipped-*.txt
#   n-sweep           evaluate-womd-interactive-n{10,50}.txt
#   reactive          evaluate-{womd-interactive,ngsim}-reactive.txt
#   n100              evaluate-womd-interactive-n100.txt (7 min on 2 cores)
#   approach-none     approach-none/*.txt: the paper's protocol, one variant a
#                     scene (the adversary engages at the first token)
#   wide-region       mutants-{womd-interactive,ngsim}-evasive-n{60,100}.txt,
#                     mutants-ngsim-lane-follower-n{60,100}.txt and
#                     mutants-womd-interactive-lane-follower-n60.txt: log replay, the
#                     prior and safer-in-path over wider trust regions (the NGSIM
#                     suite's 60), mutants-ngsim-lane-follower-n60-reactive.txt (the
#                     recorded cars brake for the ego); evaluate-ngsim-in-path-n{60,100}.txt
#                     (about 55 minutes)
#   cut-in            cut-in/: safer-cut-in beside safer-in-path, log replay and the
#                     prior: mutants-{ngsim,womd-interactive}-evasive-n60.txt,
#                     mutants-womd-interactive-evasive.txt (n = 20), the two
#                     evasive tables again with --seed 1000 (*-seed1000.txt),
#                     mutants-ngsim-lane-follower-n60.txt,
#                     mutants-womd-interactive-lane-follower.txt (n = 20), and the paper's
#                     protocol on NGSIM, evaluate-ngsim-n60.txt (about 50 minutes)
#   merging           merging/evaluate-{womd-interactive,womd-json}.txt: every scene
#                     with a pair of vehicles in merging lanes (--roles merging), log
#                     replay, the prior, safer, safer-in-path, safer-cut-in and
#                     safer-in-path-lookahead (about 2 minutes; no NGSIM scene has
#                     such a pair, and the command says so)
#   in-path-lookahead in-path-lookahead/: safer-in-path-lookahead beside safer-in-path,
#                     log replay and the prior (n = 20): the paper's protocol,
#                     evaluate-{womd-interactive,womd-json,ngsim}.txt, and
#                     mutants-{womd-interactive,ngsim}-evasive.txt, the first again
#                     with --seed 1000, 2000 and 3000 (mutants-womd-interactive-evasive-seedN.txt),
#                     and the lane follower's on WOMD interactive
#                     (mutants-womd-interactive-lane-follower.txt) (about an hour)
#   in-path-lookahead-n30
#                     in-path-lookahead/n30/: the same tables as in-path-lookahead over a
#                     trust region of 30 (--trust-region 30), where the lookahead's CR
#                     passes 0.7 on WOMD interactive, and the lane follower's on NGSIM
#                     too (mutants-ngsim-lane-follower.txt) (about 80 minutes)
#   in-path-lookahead-n28
#                     in-path-lookahead/n28/: the evasive planner's mutation tables on
#                     WOMD interactive (four draws of seeds) with the lookahead over 28
#                     behaviours, the smallest region of the sweep below whose CR passes
#                     0.7 there (about 45 minutes)
#   in-path-lookahead-sweep
#                     in-path-lookahead/sweep-n{25,27,28,40,60,100}.txt: safer-in-path-lookahead
#                     alone on WOMD interactive (10 seeds) over 25, 27, 28, 40, 60 and 100 behaviours,
#                     beside n = 20 and 30 above (about 8 minutes)
#   pair-in-traffic   pair-in-traffic/: the in-path methods with `--feasibility pair-in-traffic`
#                     (V_h and the ego's room among the traffic) over 30 behaviours beside
#                     in-path-lookahead/n30/: the paper's protocol, evaluate-{womd-interactive,
#                     womd-json,ngsim}.txt (the prior, safer-in-path, safer-in-path-lookahead),
#                     the lookahead over 28 on WOMD interactive
#                     (evaluate-womd-interactive-lookahead-n28.txt), and the evasive planner's
#                     mutation tables on NGSIM (mutants-ngsim-evasive.txt) and on WOMD
#                     interactive over 28 (mutants-womd-interactive-evasive-n28.txt); and the
#                     shipped NGSIM suite's safer-in-path over 60 behaviours, the paper's protocol
#                     and the mutation table (evaluate-ngsim-in-path-n60.txt,
#                     mutants-ngsim-evasive-n60.txt) (about 35 minutes)
#   witnessed         witnessed/: the in-path methods with `--feasibility witnessed` (V_h and
#                     the feasibility witness before a contact) over 30 behaviours beside
#                     in-path-lookahead/n30/ and pair-in-traffic/: the paper's protocol,
#                     evaluate-{womd-interactive,womd-json,ngsim}.txt (the prior,
#                     safer-in-path, safer-in-path-lookahead), the lookahead over 28 on
#                     WOMD interactive and NGSIM (evaluate-*-lookahead-n28.txt), and the
#                     evasive planner's mutation tables of the lookahead on NGSIM and WOMD
#                     interactive (mutants-{ngsim,womd-interactive}-evasive.txt) (about 65 minutes)
#   wide-witnessed    wide-witnessed/: safer-in-path and safer-cut-in on NGSIM over 100 and
#                     150 behaviours with `--feasibility witnessed`: the paper's protocol,
#                     evaluate-ngsim-n{100,150}.txt (the prior beside them), the same over 150
#                     with V_h alone (evaluate-ngsim-n150-pair.txt; over 100 it is
#                     cut-in/evaluate-ngsim-n100.txt), and the evasive planner's mutation
#                     tables over 150 (mutants-ngsim-evasive-n150.txt) and, for safer-in-path,
#                     over the NGSIM suite's 60 (mutants-ngsim-evasive-n60{,-seed1000}.txt,
#                     the second with --seed 1000) (about 50 minutes)
#   ten-seeds         ten-seeds/: the evasive planner's mutation tables over 10 seeds a
#                     scene, as the paper's protocol draws them: WOMD interactive (n = 20;
#                     log replay, the prior, safer, safer-in-path, safer-in-path-lookahead)
#                     and NGSIM (n = 60; log replay, the prior, safer, safer-in-path), and
#                     the Python lane follower's on WOMD interactive (log replay, the
#                     prior, safer-in-path) and on NGSIM (n = 60; log replay, the prior,
#                     and safer-in-path, then safer-cut-in: the two shipped suites that
#                     run external planners take the one that kills more), and on WOMD
#                     interactive and NGSIM as those suites run (n = 60, reactive-log-replay)
#                     (about 3 hours 50 minutes on 2 cores)
#   reaction-delay    reaction-delay/: the stage-2 CBV seeing the planner's ego a reaction
#                     time late (--stage2-cbv closed-loop-delayed) beside closed-loop, for log
#                     replay, the prior and safer-in-path: the evasive planner's mutation
#                     tables on WOMD interactive (n = 20) and NGSIM (n = 60), as the shipped
#                     suites are set, over two draws of seeds (the second with --seed 1000)
#                     (about 45 minutes)
#   reactive-background
#                     recorded-cars-braking/: the recorded cars braking for road users in their
#                     way (--background reactive-log-replay) with the stage-2 CBV closed loop,
#                     for log replay, the prior and safer-in-path: the evasive planner's
#                     mutation tables on WOMD interactive (n = 20) and NGSIM (n = 60) over two
#                     draws of seeds, to set beside the closed-loop rows of reaction-delay/
#                     (the same runs with the recording replayed), and ten seeds on NGSIM
#                     beside ten-seeds/ (about 40 minutes); reactive-background/ holds the
#                     same runs made by an earlier build, with the in-path loss in lead steps
#   leader            leader/: the ego's leader as the CBV (--roles leader): the paper's
#                     protocol on NGSIM over 20 and 60 behaviours (evaluate-ngsim{,-n60}.txt),
#                     the evasive planner's mutation tables with the recorded cars braking
#                     (mutants-womd-interactive-evasive.txt, mutants-ngsim-evasive-n60.txt,
#                     beside reactive-background/'s first draw, the same runs with the
#                     scenes' own pairs), and the lane follower's over 60 behaviours on
#                     both sets, with the leader and, beside it, with the scenes' own pairs
#                     (mutants-{womd-interactive,ngsim}-lane-follower-n60{,-as-loaded}.txt),
#                     and the lane follower's on NGSIM over ten seeds with the leader
#                     (mutants-ngsim-lane-follower-n60-ten-seeds.txt) (about 90 minutes)
#   first-contact     first-contact/: the paper's protocol for safer-in-path on WOMD
#                     interactive (n = 20) and NGSIM (n = 60), and the runs of
#                     reactive-background/ and leader/ (but the lane follower's ten seeds) made again with the in-path loss taking the
#                     exact time of first contact, into first-contact/reactive-background/ and
#                     first-contact/leader/; the outputs under reactive-background/ and
#                     leader/ themselves were made with the loss in lead steps of 0.5 s,
#                     which those jobs no longer reproduce (about 90 minutes)
#   both-pairings     both-pairings/: the evasive planner's mutation tables as the shipped
#                     NGSIM suite tests a scene, with the scenes' own pairs and with the
#                     ego's leader as the CBV, on WOMD interactive (n = 20) and NGSIM
#                     (n = 60), two draws of seeds each, and scene-kills-*.txt: per fault,
#                     the scenes where either pairing caught it (scene_kills_union.py over
#                     the runs' --json reports, kept in a scratch folder) (about 15 minutes)
#   first-contact-lookahead
#                     first-contact/in-path-lookahead/: safer-in-path-lookahead with the
#                     in-path loss at the first contact, the paper's protocol and the
#                     evasive planner's mutation tables over two draws of seeds: on WOMD
#                     interactive over 20 and 28 behaviours (mutation over 28), on NGSIM
#                     over 30 and 60 (mutation over 60, the shipped suites' region) and
#                     over 60 with the witness asked; the lane follower's mutation tables
#                     over 60 on both sets (about 80 minutes)
#   blind-twin        blind-twin/: safer-in-path over ten seeds, the evasive planner, the CBV
#                     closed loop and the recorded cars braking, with the CBV-blind mutant
#                     alone planted: whether the critical conflicts kept beyond 1 m of the
#                     planner would have hit it (WOMD interactive over 20 behaviours, NGSIM
#                     over 60, the shipped suite's region), and the lookahead over 28 on WOMD
#                     interactive, with V_h alone and with the witness asked (about 15 minutes)
#   ego-contact       ego-contact/: the in-path methods with `--ego-contact not-from-behind` (no
#                     contact from behind the ego): the evasive planner's mutation tables, the
#                     CBV closed loop and the recorded cars braking, of the lookahead over 28 on
#                     WOMD interactive, over two draws of seeds
#                     (mutants-womd-interactive-evasive-n28{,-seed1000}.txt), and of
#                     safer-in-path and the lookahead over 60 on NGSIM, over two draws
#                     (mutants-ngsim-evasive-n60{,-seed1000}.txt), beside first-contact/; the
#                     lane follower's, the lookahead over 60 with the scenes' own pairs
#                     (mutants-{ngsim,womd-interactive}-lane-follower-n60.txt); and the paper's
#                     protocol on WOMD interactive over 28, with the rule and with any contact
#                     (evaluate-womd-interactive-n28{,-any}.txt), and the lookahead's n-sweep
#                     with the rule (sweep-n{20,40,60,100}.txt) (about 80 minutes)
#   wrong-way         wrong-way/: the CBV kept from driving against a lane's traffic
#                     (`--wrong-way forbidden`) and not (`allowed`), side by side: the paper's
#                     protocol on WOMD interactive, the in-path methods over 28 with no contact
#                     from behind (evaluate-womd-interactive-n28-{forbidden,allowed}.txt) and
#                     `safer` over 20 (evaluate-womd-interactive-safer-*.txt); NGSIM over 60,
#                     the CBV closed loop and the recorded cars braking
#                     (evaluate-ngsim-n60-*.txt), and WOMD interactive so without the rule
#                     (evaluate-womd-interactive-n28-closed-loop-allowed.txt); and the evasive
#                     planner's mutation tables with the rule and no contact from behind,
#                     beside ego-contact/'s, over two draws of seeds
#                     (mutants-{womd-interactive-evasive-n28,ngsim-evasive-n60}{,-seed1000}.txt)
#                     (about 40 minutes)
#   lane-follower-pairings
#                     lane-follower-pairings/: the lane follower's mutation tables with no
#                     contact from behind (the lookahead over 60, the CBV closed loop, the
#                     recorded cars braking), with the scenes' own pairs
#                     (mutants-{ngsim,womd-interactive}-lane-follower-n60-as-loaded.txt, as
#                     ego-contact/'s) and with the ego's leader as the CBV (-leader.txt), and the
#                     faults caught per scene with either pairing, as the shipped suite tests a
#                     scene (scene-kills-{ngsim,womd-interactive}.txt) (about 60 minutes)
#   at-fault-planner  at-fault-planner/: the evasive planner avoiding only the contacts it
#                     would be at fault for (planners/evasive-at-fault.yaml) beside the shipped
#                     one: the mutation tables of ego-contact/'s first draw with it
#                     (mutants-{ngsim-n60,womd-interactive-n28}.txt), and the shipped NGSIM
#                     suite run with each planner, with the suite's safer-in-path and with
#                     the lookahead (suite-ngsim-{in-path,lookahead}-{evasive,at-fault}.txt)
#                     (about 12 minutes)
#   along-the-lanes   along-the-lanes/: the lookahead with the CBV kept along the lanes
#                     (`--wrong-way along-the-lanes`: neither against the traffic nor across
#                     the lanes), no contact from behind, with the evasive planner and with
#                     planners/evasive-at-fault.yaml: the mutation tables of ego-contact/'s
#                     first draw (mutants-{ngsim-n60,womd-interactive-n28}-{evasive,at-fault}.txt),
#                     and the shipped NGSIM suite with the lookahead so set
#                     (suite-ngsim-{evasive,at-fault}.txt) (about 20 minutes)
#   along-the-lanes-lane-follower
#                     along-the-lanes/: the same for the Python lane follower over 60
#                     behaviours, beside ego-contact/'s
#                     (mutants-{ngsim,womd-interactive}-lane-follower-n60.txt)
#   sideways          sideways/: how briskly each method's CBV moves sideways across its
#                     lanes in stage 1, beside the recorded CBV's, and how briskly it
#                     changes lanes, beside the recorded lane changes, on NGSIM (over 60) and
#                     WOMD interactive (over 28), no contact from behind, along the lanes
#                     (evaluate-{ngsim-n60,womd-interactive-n28}.txt) (about 5 minutes)
#   kill-ratios       kill-ratios/: along-the-lanes/'s mutation tables of the evasive planner
#                     and the Python lane follower made again with the kill ratios over
#                     resampled scenes (mutants-{ngsim-n60,womd-interactive-n28}-evasive.txt,
#                     mutants-{ngsim,womd-interactive}-lane-follower-n60.txt) (about 45 minutes)
#   human-lane-changes
#                     human-lane-changes/: kill-ratios/'s four runs with the CBV's lane changes
#                     also held to recorded drivers' sideways pace (--wrong-way
#                     human-lane-changes) (about 45 minutes)
#   grip              grip/: the CBV held within the tyres' grip (the plausibility rule's bound of
#                     9 m/s² sideways): the paper's protocol on WOMD interactive, log replay,
#                     the prior, safer and safer-in-path over 20
#                     (evaluate-womd-interactive.txt) and the lookahead over 28 with no
#                     contact from behind (evaluate-womd-interactive-lookahead-n28.txt), and
#                     kill-ratios/'s four runs (mutants-{ngsim-n60,womd-interactive-n28}-evasive.txt,
#                     mutants-{ngsim,womd-interactive}-lane-follower-n60.txt) (about 60 minutes)
#   turning           turning/: the CBV held to turning at most 4 m/s² sideways
#                     (--max-lateral-accel 4, about the 95th percentile of the recorded CBVs'
#                     peaks): grip/'s paper-protocol runs of safer, safer-in-path and the
#                     lookahead, and its four mutation runs (about 70 minutes)
#   turning-cost      turning-cost/: a turn costing 0.1 m per m/s² of the CBV's lateral
#                     acceleration in its loss (--turning-cost 0.1): the turning job's six
#                     runs (about 70 minutes)
#   turning-cost-sweep
#                     turning-cost/sweep/: the lookahead alone at turning costs of 0.05, 0.25,
#                     0.5 and 1 m per m/s², beside turning-cost/'s 0.1 and grip/'s none: the
#                     paper's protocol on WOMD interactive over 28
#                     (evaluate-womd-interactive-lookahead-n28-cC.txt) and the evasive
#                     planner's mutation tables under the suite's settings on WOMD
#                     interactive over 28 and NGSIM over 60
#                     (mutants-{womd-interactive-n28,ngsim-n60}-evasive-cC.txt) (about 15 minutes)
#   ten-seeds-lookahead
#                     ten-seeds/lookahead/: grip/'s mutation runs of the shipped lookahead suite's
#                     settings over ten seeds a scene: the evasive planner's on WOMD interactive
#                     over 28 and on NGSIM over 60 (log replay, the prior and the lookahead,
#                     mutants-{womd-interactive-n28,ngsim-n60}-evasive.txt) and the Python lane
#                     follower's over 60 (the lookahead alone: each of its runs plays a planner
#                     process per variant and mutant,
#                     mutants-{womd-interactive,ngsim}-lane-follower-n60.txt) (about 45 minutes)
#   cut-in-anticipation
#                     cut-in-anticipation/: the Python lane follower's mutation runs of the
#                     shipped lookahead suite's settings, as grip/ (3 seeds: log replay, the
#                     prior and the lookahead) and ten-seeds/lookahead/ (ten-seeds/: the
#                     lookahead alone) make them, with the follower braking for a car
#                     cutting in a second before it is in
#                     (mutants-{womd-interactive,ngsim}-lane-follower-n60.txt) (about 45 minutes)
#   standing-berth
#                     standing-berth/: ten-seeds/lookahead/'s two runs of the evasive planner
#                     (mutants-{womd-interactive-n28,ngsim-n60}-evasive.txt), with the planner
#                     keeping a berth beside a car stopped in its lane (about 25 minutes)
#   turning-circle
#                     turning-circle/: the CBV held to a car's turning circle: the paper's
#                     protocol on WOMD interactive (evaluate-womd-interactive.txt: log replay,
#                     the prior, safer and safer-in-path; the lookahead over 28,
#                     evaluate-womd-interactive-lookahead-n28.txt) and on NGSIM
#                     (evaluate-ngsim.txt), standing-berth/'s two runs of the evasive
#                     planner, and cut-in-anticipation/'s four of the lane follower
#                     (about 75 minutes). turning-circle/without/ holds the paper's
#                     protocol's runs made without the bound (this checkout with
#                     src/policies/adversary/{grip,continuations}.rs as of commit 90feb7d;
#                     grip.rs is turning_limit.rs now)
#   bumper            bumper/: the CBV off the ego's bumper: the suites' method on NGSIM
#                     under the shipped suites' rules over 60 behaviours, ten seeds
#                     (evaluate-ngsim-n60.txt; WOMD interactive's, over 28, is
#                     readme-results/evaluate-womd-interactive-default.txt),
#                     turning-circle/'s two runs of the evasive planner and its
#                     lane follower's runs, three seeds and ten (ten-seeds/; about 90
#                     minutes).
#                     bumper/before/ holds the two evaluate runs made with the build
#                     before the rule
#   womd-json-suites  womd-json-suites/: the shipped lookahead suite's settings on WOMD JSON
#                     (the CBV closed loop, the recorded cars braking, no contact from
#                     behind, along the lanes, all seven mutants): the evasive planner over
#                     28 behaviours, ten seeds (mutants-womd-json-n28-evasive.txt), and the
#                     lane follower over 60, three seeds
#                     (mutants-womd-json-lane-follower-n60.txt) and ten, the lookahead
#                     alone (ten-seeds/mutants-womd-json-lane-follower-n60.txt)
#   readme-results    readme-results/: the README's results table, the paper's protocol on
#                     WOMD interactive with this build: every method of the table over 20
#                     (evaluate-womd-interactive.txt) and the suites' method over 28 with no
#                     contact from behind (evaluate-womd-interactive-default.txt; about 12
#                     minutes)
#   closest-approach  closest-approach/evaluate-{womd-interactive,womd-json,ngsim}.txt:
#                     the paper's protocol over 20 (safer, safer-in-path, the lookahead,
#                     no-lfr, no-trust-region and the prior), for how close each
#                     method's CBV comes to the recorded ego (about 15 minutes)
#   crossing          crossing/evaluate-{womd-interactive,womd-json,ngsim}.txt: every
#                     scene with a car whose recorded path crosses the ego's (--roles
#                     crossing), log replay, the prior, safer and the suites' method
#                     (over 28 on the WOMD sets, 60 on NGSIM; no contact from behind)
#                     (about 3 minutes)
#   crossing-pairings crossing/: the lane follower under the suites' settings over 60,
#                     ten seeds, the lookahead alone, on the WOMD JSON scenes with a
#                     crossing pair, with their own pairs and with --roles crossing
#                     (mutants-womd-json-lane-follower-n60-{as-loaded,crossing}.txt),
#                     and the faults either pairing catches per scene
#                     (scene-kills-womd-json-lane-follower.txt) (about 12 minutes)
#   default-sweep     default-sweep/sweep-n{20,28,40,60,100}.txt: the suites' method
#                     (safer-in-path-lookahead, no contact from behind) in the paper's
#                     protocol on WOMD interactive, ten seeds, over 20 to 100 behaviours,
#                     and with any contact over 20, 25, 27, 28, 30, 40, 60 and 100
#                     (any-nN.txt) (about 12 minutes)
#   closed-loop-failures
#                     closed-loop-failures/evaluate-{womd-interactive,womd-json,ngsim}-{safer,suites}.txt:
#                     the evasive planner's stage-2 failures with the CBV closed loop, ten
#                     seeds, beside log replay's: the paper's method as it stands (n = 20,
#                     the recording replayed) and the suites' method as the shipped suites set
#                     it (over 28 on the WOMD sets, 60 on NGSIM; the recorded cars braking, no
#                     contact from behind, along the lanes) (about 25 minutes)
#   mutants           mutants/mutants-{womd-interactive,womd-json,ngsim}-evasive.txt and
#                     mutants/mutants-{womd-interactive,ngsim}-lane-follower.txt: the
#                     faults of the planner each method's variants catch
#                     (every fault operator, stage-2 CBV closed loop) (about 50
#                     minutes). The same names directly in this folder are the
#                     earlier build's runs that the record's comparisons quote
#                     beside their wider regions; no job remakes them
#
# Each table ends with its own wall time; the last runs' add up to about 4.5 hours on a
# 2-core machine, much of it shared with other runs. The recorded sets are
# read through `data:` ($SAFER_DATA_DIR); the s/variant
# and wall-time figures are those of the machine it runs on.
set -euo pipefail
: "${SAFER_DATA_DIR:?set SAFER_DATA_DIR to the folder of the recorded datasets}"
self=$(realpath "$0")
cd "$(dirname "$self")"
all=(evaluate plain inattentive held-out-chance trust-region realism prior-fit n-sweep reactive n100 approach-none merging mutants wide-region cut-in
    in-path-lookahead in-path-lookahead-n30 in-path-lookahead-n28 in-path-lookahead-sweep pair-in-traffic witnessed wide-witnessed ten-seeds reaction-delay reactive-background leader first-contact both-pairings first-contact-lookahead blind-twin ego-contact wrong-way
    lane-follower-pairings at-fault-planner along-the-lanes along-the-lanes-lane-follower sideways kill-ratios human-lane-changes grip turning turning-cost turning-cost-sweep ten-seeds-lookahead cut-in-anticipation standing-berth turning-circle bumper womd-json-suites readme-results closest-approach crossing crossing-pairings default-sweep closed-loop-failures)
jobs=("$@")
[[ ${#jobs[@]} -gt 0 ]] || jobs=("${all[@]}")
# The usage is the comment block at the top of this file.
usage() { awk 'NR > 1 && !/^#/ { exit } NR > 1 { sub(/^# ?/, ""); print }' "$self"; }
for job in "${jobs[@]}"; do
    case $job in -h | --help) usage; exit 0 ;; esac
    [[ " ${all[*]} " == *" $job "* ]] || { usage >&2; echo "error: no job $job" >&2; exit 2; }
done
(cd ../.. && cargo build --release --quiet)
# A copy, so that a rebuild while this runs cannot change the binary halfway.
safer=$(mktemp -d)/safer
cp ../../target/release/safer "$safer"

# run OUT ARGS...: safer ARGS, its output and warnings into OUT, then the wall time.
run() {
    local out=$1 start
    shift
    echo "== $out"
    start=$(date +%s)
    # Progress lines (a count of variants done every 30 s) are the run's, not the table's.
    "$safer" "$@" >"$out.raw" 2>&1
    grep -Ev '^[a-z-]+: ([0-9]+/[0-9]+ (variants|scenes) done|[0-9]+ (variants|scenes) to run|loading the scenes|each variant runs)' \
        "$out.raw" >"$out.tmp" || true
    rm "$out.raw"
    echo "(wall time $(($(date +%s) - start)) s)" >>"$out.tmp"
    mv "$out.tmp" "$out"
}

# The rules the shipped lookahead suite sets, with mutants planted (the along-the-lanes jobs and
# kill-ratios); the Python lane follower's runs add its own settings.
along_the_lanes=(--seeds 3 --stage2-cbv closed-loop --background reactive-log-replay --mutants --ego-contact not-from-behind
    --wrong-way along-the-lanes --methods log,prior,safer-in-path-lookahead)
along_the_lanes_lane_follower=("${along_the_lanes[@]}" --trust-region 60 --roles as-loaded
    --planner ../../planners/lane-follower.yaml)

# lane_follower_runs DIR: the Python lane follower under the shipped lookahead suite's settings over
# 60 behaviours on NGSIM and WOMD interactive: three seeds with log replay and the prior beside the
# lookahead (DIR/mutants-SET-lane-follower-n60.txt), and ten seeds of the lookahead alone
# (DIR/ten-seeds/mutants-SET-lane-follower-n60.txt).
lane_follower_runs() {
    local dir=$1 s
    local ten_lane_follower=(--seeds 10 "${along_the_lanes_lane_follower[@]:2}")
    mkdir -p "$dir/ten-seeds"
    for s in commonroad-ngsim:ngsim womd-interactive:womd-interactive; do
        run "$dir/mutants-${s#*:}-lane-follower-n60.txt" evaluate --scenes "data:${s%%:*}" \
            "${along_the_lanes_lane_follower[@]}"
        run "$dir/ten-seeds/mutants-${s#*:}-lane-follower-n60.txt" evaluate \
            --scenes "data:${s%%:*}" "${ten_lane_follower[@]/%log,prior,safer-in-path-lookahead/safer-in-path-lookahead}"
    done
}

# seed_suffix DRAW: what an output's name ends with for a draw of seeds (--seed DRAW): nothing
# for the first draw (0), -seedDRAW for the others.
seed_suffix() { [[ $1 == 0 ]] || echo "-seed$1"; }

# mutants_two_draws DIR ARGS...: the evasive planner's mutation tables of log replay, the prior
# and safer-in-path as the shipped suites are set (n = 20 on WOMD interactive, 60 on NGSIM), with
# ARGS, over two draws of seeds (the second with --seed 1000), into DIR.
mutants_two_draws() {
    local dir=$1 draw suffix
    shift
    mkdir -p "$dir"
    for draw in 0 1000; do
        suffix=$(seed_suffix "$draw")
        run "$dir/mutants-womd-interactive-evasive$suffix.txt" evaluate --scenes data:womd-interactive \
            --seeds 3 --seed "$draw" --mutants --methods log,prior,safer-in-path "$@"
        run "$dir/mutants-ngsim-evasive-n60$suffix.txt" evaluate --scenes data:commonroad-ngsim \
            --seeds 3 --seed "$draw" --mutants --methods log,prior,safer-in-path --trust-region 60 "$@"
    done
}

sets=(womd-interactive:womd-interactive womd-json:womd-json commonroad-ngsim:ngsim)
every=safer,safer-in-path,safer-cut-in,safer-distinct,safer-lookahead,safer-inattentive,no-lfr,no-trust-region,no-mda,prior,log
all_but_plain=${every/no-mda,/}
for job in "${jobs[@]}"; do
    case $job in
    evaluate)
        for s in "${sets[@]}"; do
            run "evaluate-${s#*:}.txt" evaluate --scenes "data:${s%%:*}" --seeds 10 --methods "$all_but_plain"
        done ;;
    plain)
        for s in "${sets[@]}"; do run "evaluate-${s#*:}-no-mda.txt" evaluate --scenes "data:${s%%:*}" --seeds 10 --methods no-mda; done
        run realism-prior-plain-womd16.txt realism --scenes data:womd-json --policy prior-plain --rollouts 32 --max-scenes 16
        for s in "${sets[@]%%:*}"; do
            "$safer" prior-fit --scenes "data:$s" --prior plain >"prior-fit/shipped-plain-$s.txt"
        done ;;
    inattentive)
        for s in "${sets[@]}"; do
            run "evaluate-${s#*:}-inattentive.txt" evaluate --scenes "data:${s%%:*}" --seeds 10 --methods safer-inattentive
        done ;;
    held-out-chance)
        for s in "${sets[@]}"; do
            run "held-out-chance-${s%%:*}.txt" evaluate --scenes "data:${s%%:*}" --seeds 10 --methods safer,safer-inattentive,prior
        done ;;
    trust-region)
        for s in "${sets[@]}"; do
            run "trust-region-${s%%:*}.txt" trust-region --scenes "data:${s%%:*}" --seeds 3
            run "trust-region-${s#*:}-inattentive.txt" trust-region --scenes "data:${s%%:*}" --seeds 3 \
                --methods safer,safer-inattentive
        done ;;
    realism)
        run realism-prior-womd-json-8.txt realism --scenes data:womd-json --policy prior --rollouts 8
        run realism-prior-proto.txt realism --scenes data:womd-tfrecord --policy prior --rollouts 32
        run realism-prior-womd16.txt realism --scenes data:womd-json --policy prior --rollouts 32 --max-scenes 16
        run realism-prior-ngsim.txt realism --scenes data:commonroad-ngsim --policy prior --rollouts 32
        run realism-prior-womd-all.txt realism --scenes data:womd-json --policy prior --rollouts 32 ;;
    prior-fit)
        for s in "${sets[@]%%:*}"; do
            "$safer" prior-fit --scenes "data:$s" >"prior-fit/shipped-$s.txt"
        done ;;
    n-sweep)
        for n in 10 50; do
            run "evaluate-womd-interactive-n$n.txt" evaluate --scenes data:womd-interactive --seeds 10 \
                --methods safer,safer-in-path,safer-distinct,safer-lookahead --trust-region "$n"
        done ;;
    reactive)
        for s in womd-interactive:womd-interactive commonroad-ngsim:ngsim; do
            run "evaluate-${s#*:}-reactive.txt" evaluate --scenes "data:${s%%:*}" --seeds 10 --methods "$every" \
                --background reactive-log-replay
        done ;;
    n100)
        run evaluate-womd-interactive-n100.txt evaluate --scenes data:womd-interactive --seeds 10 \
            --methods safer,safer-in-path,safer-distinct,safer-lookahead --trust-region 100 ;;
    approach-none)
        once=(--approach-phase none --seeds 1)
        for s in womd-interactive womd-json commonroad-ngsim; do
            run "approach-none/evaluate-$s.txt" evaluate --scenes "data:$s" "${once[@]}" \
                --methods safer,safer-inattentive,safer-lookahead,no-lfr,no-trust-region
        done
        for n in 10 50 100; do
            run "approach-none/evaluate-womd-interactive-n$n.txt" evaluate --scenes data:womd-interactive "${once[@]}" \
                --methods safer,safer-inattentive --trust-region "$n"
        done
        run approach-none/evaluate-womd-interactive-lookahead-n100.txt evaluate --scenes data:womd-interactive \
            "${once[@]}" --methods safer-lookahead,safer-distinct --trust-region 100
        for s in womd-json commonroad-ngsim; do
            run "approach-none/evaluate-$s-lookahead-n100.txt" evaluate --scenes "data:$s" "${once[@]}" \
                --methods safer-lookahead --trust-region 100
        done
        run approach-none/trust-region-womd-interactive.txt trust-region --scenes data:womd-interactive "${once[@]}" \
            --methods safer,safer-inattentive ;;
    merging)
        mkdir -p merging
        # NGSIM's freeway maps have no lane that two lanes lead into, and its
        # junctions' pairs reach the merge point too far apart in time.
        for s in "${sets[@]:0:2}"; do
            run "merging/evaluate-${s#*:}.txt" evaluate --scenes "data:${s%%:*}" --seeds 10 --roles merging \
                --methods log,prior,safer,safer-in-path,safer-cut-in,safer-in-path-lookahead
        done ;;
    first-contact)
        # The runs of reactive-background and leader, with the in-path loss at the first contact.
        mkdir -p first-contact/reactive-background first-contact/leader
        # The paper's protocol with the scenes' own pairs, beside the safer-in-path rows of
        # evaluate-womd-interactive.txt and evaluate-ngsim-in-path-n60.txt.
        run first-contact/evaluate-womd-interactive-in-path.txt evaluate --scenes data:womd-interactive --seeds 10 \
            --methods safer-in-path,prior
        run first-contact/evaluate-ngsim-in-path-n60.txt evaluate --scenes data:commonroad-ngsim --seeds 10 \
            --methods safer-in-path,prior --trust-region 60
        mutants_two_draws first-contact/reactive-background --stage2-cbv closed-loop --background reactive-log-replay
        run first-contact/reactive-background/mutants-ngsim-evasive-n60-ten-seeds.txt evaluate \
            --scenes data:commonroad-ngsim --seeds 10 --stage2-cbv closed-loop --background reactive-log-replay \
            --mutants --methods log,prior,safer-in-path --trust-region 60
        run first-contact/leader/evaluate-ngsim.txt evaluate --scenes data:commonroad-ngsim --seeds 10 --roles leader \
            --methods prior,safer,safer-in-path
        run first-contact/leader/evaluate-ngsim-n60.txt evaluate --scenes data:commonroad-ngsim --seeds 10 \
            --roles leader --methods prior,safer-in-path --trust-region 60
        mutating=(--seeds 3 --stage2-cbv closed-loop --background reactive-log-replay --mutants --methods log,prior,safer-in-path)
        run first-contact/leader/mutants-womd-interactive-evasive.txt evaluate --scenes data:womd-interactive \
            "${mutating[@]}" --roles leader
        run first-contact/leader/mutants-ngsim-evasive-n60.txt evaluate --scenes data:commonroad-ngsim \
            "${mutating[@]}" --trust-region 60 --roles leader
        for s in womd-interactive:womd-interactive commonroad-ngsim:ngsim; do
            for roles in leader as-loaded; do
                suffix=${roles/#leader/}
                run "first-contact/leader/mutants-${s#*:}-lane-follower-n60${suffix:+-$suffix}.txt" evaluate \
                    --scenes "data:${s%%:*}" "${mutating[@]}" --trust-region 60 --roles "$roles" \
                    --planner ../../planners/lane-follower.yaml
            done
        done ;;
    leader)
        mkdir -p leader
        run leader/evaluate-ngsim.txt evaluate --scenes data:commonroad-ngsim --seeds 10 --roles leader \
            --methods prior,safer,safer-in-path
        run leader/evaluate-ngsim-n60.txt evaluate --scenes data:commonroad-ngsim --seeds 10 --roles leader \
            --methods prior,safer-in-path --trust-region 60
        # As reactive-background/ runs the scenes' own pairs (its first draw of seeds).
        mutating=(--seeds 3 --stage2-cbv closed-loop --background reactive-log-replay --mutants --methods log,prior,safer-in-path)
        run leader/mutants-womd-interactive-evasive.txt evaluate --scenes data:womd-interactive "${mutating[@]}" \
            --roles leader
        run leader/mutants-ngsim-evasive-n60.txt evaluate --scenes data:commonroad-ngsim "${mutating[@]}" \
            --trust-region 60 --roles leader
        # The Python lane follower runs as a process per variant and mutant.
        for s in womd-interactive:womd-interactive commonroad-ngsim:ngsim; do
            for roles in leader as-loaded; do
                suffix=${roles/#leader/}
                run "leader/mutants-${s#*:}-lane-follower-n60${suffix:+-$suffix}.txt" evaluate --scenes "data:${s%%:*}" \
                    "${mutating[@]}" --trust-region 60 --roles "$roles" --planner ../../planners/lane-follower.yaml
            done
        done
        # Beside ten-seeds/mutants-ngsim-lane-follower-n60-reactive.txt (the scenes' own pairs).
        run leader/mutants-ngsim-lane-follower-n60-ten-seeds.txt evaluate --scenes data:commonroad-ngsim --seeds 10 \
            "${mutating[@]:2}" --trust-region 60 --roles leader --planner ../../planners/lane-follower.yaml ;;
    mutants)
        mkdir -p mutants
        mutating=(--stage2-cbv closed-loop --mutants)
        for s in "${sets[@]}"; do
            run "mutants/mutants-${s#*:}-evasive.txt" evaluate --scenes "data:${s%%:*}" --seeds 3 "${mutating[@]}" \
                --methods log,prior,safer,safer-in-path,safer-distinct,safer-lookahead,no-lfr
        done
        # The Python lane follower runs as a process per variant and mutant.
        for s in womd-interactive:womd-interactive commonroad-ngsim:ngsim; do
            run "mutants/mutants-${s#*:}-lane-follower.txt" evaluate --scenes "data:${s%%:*}" --seeds 2 "${mutating[@]}" \
                --methods log,prior,safer,safer-in-path,safer-distinct --planner ../../planners/lane-follower.yaml
        done ;;
    ten-seeds)
        mkdir -p ten-seeds
        mutating=(--seeds 10 --stage2-cbv closed-loop --mutants)
        run ten-seeds/mutants-womd-interactive-evasive.txt evaluate --scenes data:womd-interactive "${mutating[@]}" \
            --methods log,prior,safer,safer-in-path,safer-in-path-lookahead
        run ten-seeds/mutants-ngsim-evasive-n60.txt evaluate --scenes data:commonroad-ngsim "${mutating[@]}" \
            --methods log,prior,safer,safer-in-path --trust-region 60
        # The Python lane follower runs as a process per variant and mutant.
        run ten-seeds/mutants-womd-interactive-lane-follower.txt evaluate --scenes data:womd-interactive \
            "${mutating[@]}" --methods log,prior,safer-in-path --planner ../../planners/lane-follower.yaml
        run ten-seeds/mutants-ngsim-lane-follower-n60.txt evaluate --scenes data:commonroad-ngsim "${mutating[@]}" \
            --methods log,prior,safer-in-path --trust-region 60 --planner ../../planners/lane-follower.yaml
        run ten-seeds/mutants-ngsim-lane-follower-n60-cut-in.txt evaluate --scenes data:commonroad-ngsim \
            "${mutating[@]}" --methods log,prior,safer-cut-in --trust-region 60 --planner ../../planners/lane-follower.yaml
        # As the suites that run external planners are set: 60 behaviours, the recorded cars braking for the ego.
        run ten-seeds/mutants-womd-interactive-lane-follower-n60-reactive.txt evaluate --scenes data:womd-interactive \
            "${mutating[@]}" --methods log,prior,safer-in-path --trust-region 60 --background reactive-log-replay \
            --planner ../../planners/lane-follower.yaml
        run ten-seeds/mutants-ngsim-lane-follower-n60-reactive.txt evaluate --scenes data:commonroad-ngsim \
            "${mutating[@]}" --methods log,prior,safer-in-path --trust-region 60 --background reactive-log-replay \
            --planner ../../planners/lane-follower.yaml ;;
    wide-region)
        mutating=(--stage2-cbv closed-loop --mutants --methods log,prior,safer-in-path)
        for n in 60 100; do
            for s in womd-interactive:womd-interactive commonroad-ngsim:ngsim; do
                run "mutants-${s#*:}-evasive-n$n.txt" evaluate --scenes "data:${s%%:*}" --seeds 3 "${mutating[@]}" \
                    --trust-region "$n"
            done
            run "mutants-ngsim-lane-follower-n$n.txt" evaluate --scenes data:commonroad-ngsim --seeds 2 "${mutating[@]}" \
                --trust-region "$n" --planner ../../planners/lane-follower.yaml
        done
        run mutants-womd-interactive-lane-follower-n60.txt evaluate --scenes data:womd-interactive --seeds 2 \
            "${mutating[@]}" --trust-region 60 --planner ../../planners/lane-follower.yaml
        # The background the two suites that run external planners use: the recorded cars brake for the ego.
        run mutants-ngsim-lane-follower-n60-reactive.txt evaluate --scenes data:commonroad-ngsim --seeds 2 \
            "${mutating[@]}" --trust-region 60 --background reactive-log-replay --planner ../../planners/lane-follower.yaml
        # The paper's protocol (stage-2 CBV replayed, 10 seeds) over the wider regions on NGSIM.
        for n in 60 100; do
            run "evaluate-ngsim-in-path-n$n.txt" evaluate --scenes data:commonroad-ngsim --seeds 10 \
                --methods safer-in-path,prior --trust-region "$n"
        done ;;
    cut-in)
        mkdir -p cut-in
        mutating=(--stage2-cbv closed-loop --mutants --methods log,prior,safer-in-path,safer-cut-in)
        for s in commonroad-ngsim:ngsim womd-interactive:womd-interactive; do
            run "cut-in/mutants-${s#*:}-evasive-n60.txt" evaluate --scenes "data:${s%%:*}" --seeds 3 "${mutating[@]}" \
                --trust-region 60
        done
        run cut-in/mutants-womd-interactive-evasive.txt evaluate --scenes data:womd-interactive --seeds 3 "${mutating[@]}"
        # Another draw of seeds: how much of a difference between two methods the seeds alone make.
        run cut-in/mutants-ngsim-evasive-n60-seed1000.txt evaluate --scenes data:commonroad-ngsim --seeds 3 --seed 1000 \
            "${mutating[@]}" --trust-region 60
        run cut-in/mutants-womd-interactive-evasive-seed1000.txt evaluate --scenes data:womd-interactive --seeds 3 \
            --seed 1000 "${mutating[@]}"
        for n in 60 100; do
            run "cut-in/evaluate-ngsim-n$n.txt" evaluate --scenes data:commonroad-ngsim --seeds 10 \
                --methods prior,safer-in-path,safer-cut-in --trust-region "$n"
        done
        run cut-in/mutants-ngsim-lane-follower-n60.txt evaluate --scenes data:commonroad-ngsim --seeds 2 \
            "${mutating[@]}" --trust-region 60 --planner ../../planners/lane-follower.yaml
        run cut-in/mutants-womd-interactive-lane-follower.txt evaluate --scenes data:womd-interactive --seeds 2 \
            "${mutating[@]}" --planner ../../planners/lane-follower.yaml ;;
    in-path-lookahead)
        mkdir -p in-path-lookahead
        for s in "${sets[@]}"; do
            run "in-path-lookahead/evaluate-${s#*:}.txt" evaluate --scenes "data:${s%%:*}" --seeds 10 \
                --methods prior,safer-in-path,safer-in-path-lookahead
        done
        mutating=(--stage2-cbv closed-loop --mutants --methods log,prior,safer-in-path,safer-in-path-lookahead)
        for s in womd-interactive:womd-interactive commonroad-ngsim:ngsim; do
            run "in-path-lookahead/mutants-${s#*:}-evasive.txt" evaluate --scenes "data:${s%%:*}" --seeds 3 "${mutating[@]}"
        done
        for seed in 1000 2000 3000; do
            run "in-path-lookahead/mutants-womd-interactive-evasive-seed$seed.txt" evaluate --scenes data:womd-interactive \
                --seeds 3 --seed "$seed" "${mutating[@]}"
        done
        run in-path-lookahead/mutants-womd-interactive-lane-follower.txt evaluate --scenes data:womd-interactive \
            --seeds 2 "${mutating[@]}" --planner ../../planners/lane-follower.yaml ;;
    in-path-lookahead-n30)
        mkdir -p in-path-lookahead/n30
        mutating=(--stage2-cbv closed-loop --mutants --methods log,prior,safer-in-path,safer-in-path-lookahead
            --trust-region 30)
        for seed in 0 1000 2000 3000; do
            run "in-path-lookahead/n30/mutants-womd-interactive-evasive-seed$seed.txt" evaluate --scenes data:womd-interactive \
                --seeds 3 --seed "$seed" "${mutating[@]}"
        done
        for s in "${sets[@]}"; do
            run "in-path-lookahead/n30/evaluate-${s#*:}.txt" evaluate --scenes "data:${s%%:*}" --seeds 10 \
                --methods prior,safer-in-path,safer-in-path-lookahead --trust-region 30
        done
        run in-path-lookahead/n30/mutants-womd-interactive-lane-follower.txt evaluate --scenes data:womd-interactive \
            --seeds 2 "${mutating[@]}" --planner ../../planners/lane-follower.yaml
        run in-path-lookahead/n30/mutants-ngsim-evasive.txt evaluate --scenes data:commonroad-ngsim --seeds 3 "${mutating[@]}"
        run in-path-lookahead/n30/mutants-ngsim-lane-follower.txt evaluate --scenes data:commonroad-ngsim \
            --seeds 2 "${mutating[@]}" --planner ../../planners/lane-follower.yaml ;;
    in-path-lookahead-n28)
        mkdir -p in-path-lookahead/n28
        mutating=(--stage2-cbv closed-loop --mutants --methods log,prior,safer-in-path-lookahead --trust-region 28)
        for seed in 0 1000 2000 3000; do
            run "in-path-lookahead/n28/mutants-womd-interactive-evasive-seed$seed.txt" evaluate --scenes data:womd-interactive \
                --seeds 3 --seed "$seed" "${mutating[@]}"
        done ;;
    in-path-lookahead-sweep)
        for n in 25 27 28 40 60 100; do
            run "in-path-lookahead/sweep-n$n.txt" evaluate --scenes data:womd-interactive --seeds 10 \
                --methods safer-in-path-lookahead --trust-region "$n"
        done ;;
    pair-in-traffic)
        mkdir -p pair-in-traffic
        traffic=(--feasibility pair-in-traffic)
        for s in "${sets[@]}"; do
            run "pair-in-traffic/evaluate-${s#*:}.txt" evaluate --scenes "data:${s%%:*}" --seeds 10 \
                --methods prior,safer-in-path,safer-in-path-lookahead --trust-region 30 "${traffic[@]}"
        done
        run pair-in-traffic/evaluate-womd-interactive-lookahead-n28.txt evaluate --scenes data:womd-interactive \
            --seeds 10 --methods safer-in-path-lookahead --trust-region 28 "${traffic[@]}"
        run pair-in-traffic/mutants-ngsim-evasive.txt evaluate --scenes data:commonroad-ngsim --seeds 3 \
            --stage2-cbv closed-loop --mutants --methods log,prior,safer-in-path,safer-in-path-lookahead \
            --trust-region 30 "${traffic[@]}"
        run pair-in-traffic/mutants-womd-interactive-evasive-n28.txt evaluate --scenes data:womd-interactive \
            --seeds 3 --stage2-cbv closed-loop --mutants --methods log,prior,safer-in-path-lookahead \
            --trust-region 28 "${traffic[@]}"
        # The shipped NGSIM suite's method and region.
        run pair-in-traffic/evaluate-ngsim-in-path-n60.txt evaluate --scenes data:commonroad-ngsim --seeds 10 \
            --methods safer-in-path,prior --trust-region 60 "${traffic[@]}"
        run pair-in-traffic/mutants-ngsim-evasive-n60.txt evaluate --scenes data:commonroad-ngsim --seeds 3 \
            --stage2-cbv closed-loop --mutants --methods log,prior,safer-in-path --trust-region 60 "${traffic[@]}" ;;
    witnessed)
        mkdir -p witnessed
        witnessed=(--feasibility witnessed)
        for s in "${sets[@]}"; do
            run "witnessed/evaluate-${s#*:}.txt" evaluate --scenes "data:${s%%:*}" --seeds 10 \
                --methods prior,safer-in-path,safer-in-path-lookahead --trust-region 30 "${witnessed[@]}"
        done
        for s in womd-interactive:womd-interactive commonroad-ngsim:ngsim; do
            run "witnessed/evaluate-${s#*:}-lookahead-n28.txt" evaluate --scenes "data:${s%%:*}" --seeds 10 \
                --methods prior,safer-in-path-lookahead --trust-region 28 "${witnessed[@]}"
        done
        for s in commonroad-ngsim:ngsim womd-interactive:womd-interactive; do
            run "witnessed/mutants-${s#*:}-evasive.txt" evaluate --scenes "data:${s%%:*}" --seeds 3 \
                --stage2-cbv closed-loop --mutants --methods log,prior,safer-in-path-lookahead --trust-region 30 \
                "${witnessed[@]}"
        done ;;
    wide-witnessed)
        mkdir -p wide-witnessed
        for n in 100 150; do
            run "wide-witnessed/evaluate-ngsim-n$n.txt" evaluate --scenes data:commonroad-ngsim --seeds 10 \
                --methods prior,safer-in-path,safer-cut-in --trust-region "$n" --feasibility witnessed
        done
        run wide-witnessed/evaluate-ngsim-n150-pair.txt evaluate --scenes data:commonroad-ngsim --seeds 10 \
            --methods prior,safer-in-path,safer-cut-in --trust-region 150
        run wide-witnessed/mutants-ngsim-evasive-n150.txt evaluate --scenes data:commonroad-ngsim --seeds 3 \
            --stage2-cbv closed-loop --mutants --methods log,prior,safer-in-path,safer-cut-in --trust-region 150 \
            --feasibility witnessed
        # The shipped NGSIM suite's method and region, with the witness asked; two draws of seeds.
        run wide-witnessed/mutants-ngsim-evasive-n60.txt evaluate --scenes data:commonroad-ngsim --seeds 3 \
            --stage2-cbv closed-loop --mutants --methods log,prior,safer-in-path --trust-region 60 \
            --feasibility witnessed
        run wide-witnessed/mutants-ngsim-evasive-n60-seed1000.txt evaluate --scenes data:commonroad-ngsim --seeds 3 \
            --seed 1000 --stage2-cbv closed-loop --mutants --methods log,prior,safer-in-path --trust-region 60 \
            --feasibility witnessed ;;
    reaction-delay) mutants_two_draws reaction-delay --stage2-cbv closed-loop,closed-loop-delayed ;;
    reactive-background)
        mutants_two_draws recorded-cars-braking --stage2-cbv closed-loop --background reactive-log-replay
        # Ten seeds on NGSIM, beside ten-seeds/mutants-ngsim-evasive-n60.txt (the recording replayed).
        run recorded-cars-braking/mutants-ngsim-evasive-n60-ten-seeds.txt evaluate --scenes data:commonroad-ngsim \
            --seeds 10 --stage2-cbv closed-loop --background reactive-log-replay --mutants \
            --methods log,prior,safer-in-path --trust-region 60 ;;
    blind-twin)
        mkdir -p blind-twin
        run blind-twin/womd-interactive-evasive.txt evaluate --scenes data:womd-interactive --seeds 10 \
            --stage2-cbv closed-loop --background reactive-log-replay --mutants blind-cbv --methods safer-in-path
        run blind-twin/womd-interactive-evasive-lookahead-n28.txt evaluate --scenes data:womd-interactive \
            --seeds 10 --stage2-cbv closed-loop --background reactive-log-replay --mutants blind-cbv \
            --methods safer-in-path-lookahead --trust-region 28
        run blind-twin/womd-interactive-evasive-lookahead-n28-witnessed.txt evaluate --scenes data:womd-interactive \
            --seeds 10 --stage2-cbv closed-loop --background reactive-log-replay --mutants blind-cbv \
            --methods safer-in-path-lookahead --trust-region 28 --feasibility witnessed
        run blind-twin/ngsim-evasive-n60.txt evaluate --scenes data:commonroad-ngsim --seeds 10 \
            --stage2-cbv closed-loop --background reactive-log-replay --mutants blind-cbv --methods safer-in-path \
            --trust-region 60 ;;
    ego-contact)
        mkdir -p ego-contact
        behind=(--seeds 3 --stage2-cbv closed-loop --background reactive-log-replay --mutants --ego-contact not-from-behind)
        for draw in 0 1000; do
            run "ego-contact/mutants-womd-interactive-evasive-n28$(seed_suffix "$draw").txt" evaluate \
                --scenes data:womd-interactive "${behind[@]}" --seed "$draw" \
                --methods log,prior,safer-in-path-lookahead --trust-region 28
        done
        for draw in 0 1000; do
            run "ego-contact/mutants-ngsim-evasive-n60$(seed_suffix "$draw").txt" evaluate \
                --scenes data:commonroad-ngsim "${behind[@]}" --seed "$draw" \
                --methods log,prior,safer-in-path,safer-in-path-lookahead --trust-region 60
        done
        # Beside first-contact/in-path-lookahead/mutants-*-lane-follower-n60.txt (any contact).
        for s in commonroad-ngsim:ngsim womd-interactive:womd-interactive; do
            run "ego-contact/mutants-${s#*:}-lane-follower-n60.txt" evaluate --scenes "data:${s%%:*}" \
                "${behind[@]}" --methods log,prior,safer-in-path-lookahead --trust-region 60 \
                --roles as-loaded --planner ../../planners/lane-follower.yaml
        done
        run ego-contact/evaluate-womd-interactive-n28.txt evaluate --scenes data:womd-interactive --seeds 10 \
            --trust-region 28 --methods safer-in-path-lookahead,safer-in-path --ego-contact not-from-behind
        # The same with any contact: how the CBV touched the ego, beside the rule's.
        run ego-contact/evaluate-womd-interactive-n28-any.txt evaluate --scenes data:womd-interactive --seeds 10 \
            --trust-region 28 --methods safer-in-path-lookahead,safer-in-path
        # The lookahead's n-sweep with the rule, beside in-path-lookahead/sweep-n*.txt (n = 28:
        # evaluate-womd-interactive-n28.txt).
        for n in 20 40 60 100; do
            run "ego-contact/sweep-n$n.txt" evaluate --scenes data:womd-interactive --seeds 10 \
                --trust-region "$n" --methods safer-in-path-lookahead --ego-contact not-from-behind
        done ;;
    wrong-way)
        mkdir -p wrong-way
        # The paper's protocol over 28 with no contact from behind, the CBV kept from driving
        # against the traffic and not (the latter: ego-contact/evaluate-womd-interactive-n28.txt
        # again, with the wrong-way columns).
        for rule in forbidden allowed; do
            run "wrong-way/evaluate-womd-interactive-n28-$rule.txt" evaluate --scenes data:womd-interactive \
                --seeds 10 --trust-region 28 --methods safer-in-path-lookahead,safer-in-path \
                --ego-contact not-from-behind --wrong-way "$rule"
            # The paper's method as the main table runs it (over 20).
            run "wrong-way/evaluate-womd-interactive-safer-$rule.txt" evaluate --scenes data:womd-interactive \
                --seeds 10 --methods log,safer --wrong-way "$rule"
            # NGSIM with the CBV closed loop and the recorded cars braking, over 60.
            run "wrong-way/evaluate-ngsim-n60-$rule.txt" evaluate --scenes data:commonroad-ngsim --seeds 3 \
                --stage2-cbv closed-loop --background reactive-log-replay --trust-region 60 \
                --methods log,safer,safer-in-path,safer-in-path-lookahead --ego-contact not-from-behind \
                --wrong-way "$rule"
        done
        # WOMD interactive as the mutation table below runs it, without the rule and the mutants:
        # how often the CBV drives the wrong way there (the NGSIM run above is that of the NGSIM
        # mutation table).
        run wrong-way/evaluate-womd-interactive-n28-closed-loop-allowed.txt evaluate \
            --scenes data:womd-interactive --seeds 3 --stage2-cbv closed-loop --background reactive-log-replay \
            --ego-contact not-from-behind --methods log,prior,safer-in-path-lookahead --trust-region 28
        # The evasive planner's mutation tables with the rule, beside ego-contact/'s.
        behind=(--seeds 3 --stage2-cbv closed-loop --background reactive-log-replay --mutants --ego-contact not-from-behind
            --wrong-way forbidden)
        for draw in 0 1000; do
            run "wrong-way/mutants-womd-interactive-evasive-n28$(seed_suffix "$draw").txt" evaluate \
                --scenes data:womd-interactive "${behind[@]}" --seed "$draw" \
                --methods log,prior,safer-in-path-lookahead --trust-region 28
            run "wrong-way/mutants-ngsim-evasive-n60$(seed_suffix "$draw").txt" evaluate \
                --scenes data:commonroad-ngsim "${behind[@]}" --seed "$draw" \
                --methods log,prior,safer-in-path,safer-in-path-lookahead --trust-region 60
        done ;;
    first-contact-lookahead)
        mkdir -p first-contact/in-path-lookahead
        for n in 20 28; do
            run "first-contact/in-path-lookahead/evaluate-womd-interactive-n$n.txt" evaluate \
                --scenes data:womd-interactive --seeds 10 --trust-region "$n" \
                --methods safer-in-path,safer-in-path-lookahead,prior
        done
        for draw in 0 1000; do
            run "first-contact/in-path-lookahead/mutants-womd-interactive-evasive-n28$(seed_suffix "$draw").txt" \
                evaluate --scenes data:womd-interactive --seeds 3 --seed "$draw" --stage2-cbv closed-loop \
                --background reactive-log-replay --mutants --methods log,prior,safer-in-path-lookahead --trust-region 28
        done
        for n in 30 60; do
            run "first-contact/in-path-lookahead/evaluate-ngsim-n$n.txt" evaluate --scenes data:commonroad-ngsim \
                --seeds 10 --trust-region "$n" --methods safer-in-path,safer-in-path-lookahead,prior
        done
        run first-contact/in-path-lookahead/evaluate-ngsim-n60-witnessed.txt evaluate --scenes data:commonroad-ngsim \
            --seeds 10 --trust-region 60 --methods prior,safer-in-path-lookahead --feasibility witnessed
        for draw in 0 1000; do
            run "first-contact/in-path-lookahead/mutants-ngsim-evasive-n60$(seed_suffix "$draw").txt" evaluate \
                --scenes data:commonroad-ngsim --seeds 3 --seed "$draw" --stage2-cbv closed-loop \
                --background reactive-log-replay --mutants --methods log,prior,safer-in-path-lookahead --trust-region 60
        done
        run first-contact/in-path-lookahead/mutants-ngsim-evasive-n60-witnessed.txt evaluate \
            --scenes data:commonroad-ngsim --seeds 3 --stage2-cbv closed-loop --background reactive-log-replay \
            --mutants --methods log,prior,safer-in-path-lookahead --trust-region 60 --feasibility witnessed
        for s in commonroad-ngsim:ngsim womd-interactive:womd-interactive; do
            run "first-contact/in-path-lookahead/mutants-${s#*:}-lane-follower-n60.txt" evaluate \
                --scenes "data:${s%%:*}" --seeds 3 --stage2-cbv closed-loop --background reactive-log-replay \
                --mutants --methods log,prior,safer-in-path-lookahead --trust-region 60 --roles as-loaded \
                --planner ../../planners/lane-follower.yaml
        done ;;
    both-pairings)
        mkdir -p both-pairings
        reports=$(mktemp -d)
        mutating=(--seeds 3 --stage2-cbv closed-loop --background reactive-log-replay --mutants --methods log,prior,safer-in-path)
        for s in womd-interactive:womd-interactive:20 commonroad-ngsim:ngsim:60; do
            set=${s#*:} && set=${set%%:*}
            for draw in 0 1000; do
                suffix=$(seed_suffix "$draw")
                for roles in as-loaded leader; do
                    name="mutants-$set-evasive-$roles$suffix"
                    run "both-pairings/$name.txt" evaluate --scenes "data:${s%%:*}" "${mutating[@]}" \
                        --trust-region "${s##*:}" --seed "$draw" --roles "$roles" --json "$reports/$name.json"
                    # The line saying where the report went names a scratch folder.
                    sed -i '/^wrote .*\.json$/d' "both-pairings/$name.txt"
                done
                python3 scene_kills_union.py "$reports/mutants-$set-evasive-as-loaded$suffix.json" \
                    "$reports/mutants-$set-evasive-leader$suffix.json" >"both-pairings/scene-kills-$set$suffix.txt"
            done
        done
        rm -r "$reports" ;;
    lane-follower-pairings)
        mkdir -p lane-follower-pairings
        reports=$(mktemp -d)
        lf=(--seeds 3 --stage2-cbv closed-loop --background reactive-log-replay --mutants --ego-contact not-from-behind
            --methods log,prior,safer-in-path-lookahead --trust-region 60 --planner ../../planners/lane-follower.yaml)
        for s in commonroad-ngsim:ngsim womd-interactive:womd-interactive; do
            set=${s#*:}
            for roles in as-loaded leader; do
                name="mutants-$set-lane-follower-n60-$roles"
                run "lane-follower-pairings/$name.txt" evaluate --scenes "data:${s%%:*}" "${lf[@]}" --roles "$roles" \
                    --json "$reports/$name.json"
                # The line saying where the report went names a scratch folder.
                sed -i '/^wrote .*\.json$/d' "lane-follower-pairings/$name.txt"
            done
            python3 scene_kills_union.py "$reports/mutants-$set-lane-follower-n60-as-loaded.json" \
                "$reports/mutants-$set-lane-follower-n60-leader.json" >"lane-follower-pairings/scene-kills-$set.txt"
        done
        rm -r "$reports" ;;
    at-fault-planner)
        mkdir -p at-fault-planner
        behind=(--seeds 3 --stage2-cbv closed-loop --background reactive-log-replay --mutants --ego-contact not-from-behind
            --planner ../../planners/evasive-at-fault.yaml)
        run at-fault-planner/mutants-ngsim-n60.txt evaluate --scenes data:commonroad-ngsim "${behind[@]}" \
            --methods log,prior,safer-in-path,safer-in-path-lookahead --trust-region 60
        run at-fault-planner/mutants-womd-interactive-n28.txt evaluate --scenes data:womd-interactive "${behind[@]}" \
            --methods log,prior,safer-in-path-lookahead --trust-region 28
        # The shipped suite as it is, and with the lookahead (no contact from behind), each
        # with either planner: scratch copies beside it, so that its relative paths hold.
        suite=../../specs/suites/adversarial-ngsim.yaml
        for method in in-path lookahead; do
            for planner in evasive at-fault; do
                copy=../../specs/suites/.adversarial-ngsim-$method-$planner.yaml
                sed -e "s#^planner: ../../planners/evasive.yaml#planner: ../../planners/$planner.yaml#" \
                    -e "s#^planner: ../../planners/at-fault.yaml#planner: ../../planners/evasive-at-fault.yaml#" "$suite" >"$copy"
                [[ $method == in-path ]] ||
                    sed -i 's#^  method: safer-in-path$#  method: safer-in-path-lookahead\n  ego_contact: not-from-behind#' "$copy"
                # A failing suite is a result here, not an error.
                run "at-fault-planner/suite-ngsim-$method-$planner.txt" run "$copy" --no-shrink --mutants all \
                    --artifacts "$(mktemp -d)" || true
                rm "$copy"
            done
        done ;;
    along-the-lanes)
        mkdir -p along-the-lanes
        along=("${along_the_lanes[@]}")
        for planner in evasive at-fault; do
            spec=../../planners/evasive.yaml
            [[ $planner == evasive ]] || spec=../../planners/evasive-at-fault.yaml
            run "along-the-lanes/mutants-ngsim-n60-$planner.txt" evaluate --scenes data:commonroad-ngsim "${along[@]}" \
                --trust-region 60 --planner "$spec"
            run "along-the-lanes/mutants-womd-interactive-n28-$planner.txt" evaluate --scenes data:womd-interactive \
                "${along[@]}" --trust-region 28 --planner "$spec"
            copy=../../specs/suites/.adversarial-ngsim-along-the-lanes-$planner.yaml
            sed -e "s#^planner: ../../planners/evasive.yaml#planner: $spec#" \
                -e 's#^  method: safer-in-path$#  method: safer-in-path-lookahead\n  ego_contact: not-from-behind\n  wrong_way: along-the-lanes#' \
                ../../specs/suites/adversarial-ngsim.yaml >"$copy"
            # A failing suite is a result here, not an error.
            run "along-the-lanes/suite-ngsim-$planner.txt" run "$copy" --no-shrink --mutants all \
                --artifacts "$(mktemp -d)" || true
            rm "$copy"
        done ;;
    along-the-lanes-lane-follower)
        mkdir -p along-the-lanes
        # Beside ego-contact/mutants-*-lane-follower-n60.txt (the CBV any way).
        for s in commonroad-ngsim:ngsim womd-interactive:womd-interactive; do
            run "along-the-lanes/mutants-${s#*:}-lane-follower-n60.txt" evaluate --scenes "data:${s%%:*}" \
                "${along_the_lanes_lane_follower[@]}"
        done ;;
    sideways)
        mkdir -p sideways
        # The paper's protocol with the rules the shipped lookahead suite sets.
        sideways=(--seeds 3 --methods log,prior,safer,safer-in-path,safer-in-path-lookahead
            --ego-contact not-from-behind --wrong-way along-the-lanes)
        run sideways/evaluate-ngsim-n60.txt evaluate --scenes data:commonroad-ngsim "${sideways[@]}" --trust-region 60
        run sideways/evaluate-womd-interactive-n28.txt evaluate --scenes data:womd-interactive "${sideways[@]}" \
            --trust-region 28 ;;
    kill-ratios)
        mkdir -p kill-ratios
        # The along-the-lanes jobs' commands of the evasive planner and the lane follower.
        along=("${along_the_lanes[@]}" --planner ../../planners/evasive.yaml)
        run kill-ratios/mutants-ngsim-n60-evasive.txt evaluate --scenes data:commonroad-ngsim "${along[@]}" --trust-region 60
        run kill-ratios/mutants-womd-interactive-n28-evasive.txt evaluate --scenes data:womd-interactive "${along[@]}" \
            --trust-region 28
        for s in commonroad-ngsim:ngsim womd-interactive:womd-interactive; do
            run "kill-ratios/mutants-${s#*:}-lane-follower-n60.txt" evaluate --scenes "data:${s%%:*}" \
                "${along_the_lanes_lane_follower[@]}"
        done ;;
    human-lane-changes)
        mkdir -p human-lane-changes
        # kill-ratios' commands with --wrong-way human-lane-changes for along-the-lanes.
        along=("${along_the_lanes[@]/#along-the-lanes/human-lane-changes}" --planner ../../planners/evasive.yaml)
        lane_follower=("${along_the_lanes_lane_follower[@]/#along-the-lanes/human-lane-changes}")
        run human-lane-changes/mutants-ngsim-n60-evasive.txt evaluate --scenes data:commonroad-ngsim "${along[@]}" \
            --trust-region 60
        run human-lane-changes/mutants-womd-interactive-n28-evasive.txt evaluate --scenes data:womd-interactive \
            "${along[@]}" --trust-region 28
        for s in commonroad-ngsim:ngsim womd-interactive:womd-interactive; do
            run "human-lane-changes/mutants-${s#*:}-lane-follower-n60.txt" evaluate --scenes "data:${s%%:*}" \
                "${lane_follower[@]}"
        done ;;
    grip)
        mkdir -p grip
        run grip/evaluate-womd-interactive.txt evaluate --scenes data:womd-interactive --seeds 10 \
            --methods log,prior,safer,safer-in-path
        run grip/evaluate-womd-interactive-lookahead-n28.txt evaluate --scenes data:womd-interactive --seeds 10 \
            --trust-region 28 --methods safer-in-path-lookahead --ego-contact not-from-behind
        # kill-ratios/'s four runs.
        along=("${along_the_lanes[@]}" --planner ../../planners/evasive.yaml)
        run grip/mutants-ngsim-n60-evasive.txt evaluate --scenes data:commonroad-ngsim "${along[@]}" --trust-region 60
        run grip/mutants-womd-interactive-n28-evasive.txt evaluate --scenes data:womd-interactive "${along[@]}" \
            --trust-region 28
        for s in commonroad-ngsim:ngsim womd-interactive:womd-interactive; do
            run "grip/mutants-${s#*:}-lane-follower-n60.txt" evaluate --scenes "data:${s%%:*}" \
                "${along_the_lanes_lane_follower[@]}"
        done ;;
    turning)
        mkdir -p turning
        turn=(--max-lateral-accel 4)
        run turning/evaluate-womd-interactive.txt evaluate --scenes data:womd-interactive --seeds 10 \
            --methods safer,safer-in-path "${turn[@]}"
        run turning/evaluate-womd-interactive-lookahead-n28.txt evaluate --scenes data:womd-interactive --seeds 10 \
            --trust-region 28 --methods safer-in-path-lookahead --ego-contact not-from-behind "${turn[@]}"
        along=("${along_the_lanes[@]}" --planner ../../planners/evasive.yaml "${turn[@]}")
        run turning/mutants-womd-interactive-n28-evasive.txt evaluate --scenes data:womd-interactive "${along[@]}" \
            --trust-region 28
        run turning/mutants-ngsim-n60-evasive.txt evaluate --scenes data:commonroad-ngsim "${along[@]}" \
            --trust-region 60
        for s in commonroad-ngsim:ngsim womd-interactive:womd-interactive; do
            run "turning/mutants-${s#*:}-lane-follower-n60.txt" evaluate --scenes "data:${s%%:*}" \
                "${along_the_lanes_lane_follower[@]}" "${turn[@]}"
        done ;;
    turning-cost)
        mkdir -p turning-cost
        cost=(--turning-cost 0.1)
        run turning-cost/evaluate-womd-interactive.txt evaluate --scenes data:womd-interactive --seeds 10 \
            --methods safer,safer-in-path "${cost[@]}"
        run turning-cost/evaluate-womd-interactive-lookahead-n28.txt evaluate --scenes data:womd-interactive \
            --seeds 10 --trust-region 28 --methods safer-in-path-lookahead --ego-contact not-from-behind "${cost[@]}"
        along=("${along_the_lanes[@]}" --planner ../../planners/evasive.yaml "${cost[@]}")
        run turning-cost/mutants-womd-interactive-n28-evasive.txt evaluate --scenes data:womd-interactive \
            "${along[@]}" --trust-region 28
        run turning-cost/mutants-ngsim-n60-evasive.txt evaluate --scenes data:commonroad-ngsim "${along[@]}" \
            --trust-region 60
        for s in commonroad-ngsim:ngsim womd-interactive:womd-interactive; do
            run "turning-cost/mutants-${s#*:}-lane-follower-n60.txt" evaluate --scenes "data:${s%%:*}" \
                "${along_the_lanes_lane_follower[@]}" "${cost[@]}"
        done ;;
    turning-cost-sweep)
        mkdir -p turning-cost/sweep
        for c in 0.05 0.25 0.5 1; do
            run "turning-cost/sweep/evaluate-womd-interactive-lookahead-n28-c$c.txt" evaluate \
                --scenes data:womd-interactive --seeds 10 --trust-region 28 --methods safer-in-path-lookahead \
                --ego-contact not-from-behind --turning-cost "$c"
            # The suite's settings, the lookahead's rows alone (its kills need no other row).
            along=("${along_the_lanes[@]/%log,prior,safer-in-path-lookahead/safer-in-path-lookahead}"
                --planner ../../planners/evasive.yaml --turning-cost "$c")
            run "turning-cost/sweep/mutants-womd-interactive-n28-evasive-c$c.txt" evaluate \
                --scenes data:womd-interactive "${along[@]}" --trust-region 28
            run "turning-cost/sweep/mutants-ngsim-n60-evasive-c$c.txt" evaluate --scenes data:commonroad-ngsim \
                "${along[@]}" --trust-region 60
        done ;;
    ten-seeds-lookahead)
        mkdir -p ten-seeds/lookahead
        # along_the_lanes with --seeds 10 for its first two words (--seeds 3).
        ten=(--seeds 10 "${along_the_lanes[@]:2}")
        run ten-seeds/lookahead/mutants-womd-interactive-n28-evasive.txt evaluate --scenes data:womd-interactive \
            "${ten[@]}" --planner ../../planners/evasive.yaml --trust-region 28
        run ten-seeds/lookahead/mutants-ngsim-n60-evasive.txt evaluate --scenes data:commonroad-ngsim "${ten[@]}" \
            --planner ../../planners/evasive.yaml --trust-region 60
        # The lookahead's rows alone: the lane follower's ratios to log replay and the prior are grip/'s,
        # over three seeds.
        ten_lane_follower=(--seeds 10 "${along_the_lanes_lane_follower[@]:2}")
        for s in womd-interactive:womd-interactive commonroad-ngsim:ngsim; do
            run "ten-seeds/lookahead/mutants-${s#*:}-lane-follower-n60.txt" evaluate --scenes "data:${s%%:*}" \
                "${ten_lane_follower[@]/%log,prior,safer-in-path-lookahead/safer-in-path-lookahead}"
        done ;;
    standing-berth)
        mkdir -p standing-berth
        ten=(--seeds 10 "${along_the_lanes[@]:2}")
        run standing-berth/mutants-womd-interactive-n28-evasive.txt evaluate --scenes data:womd-interactive \
            "${ten[@]}" --planner ../../planners/evasive.yaml --trust-region 28
        run standing-berth/mutants-ngsim-n60-evasive.txt evaluate --scenes data:commonroad-ngsim "${ten[@]}" \
            --planner ../../planners/evasive.yaml --trust-region 60 ;;
    turning-circle)
        mkdir -p turning-circle
        run turning-circle/evaluate-womd-interactive.txt evaluate --scenes data:womd-interactive --seeds 10 \
            --methods log,prior,safer,safer-in-path
        run turning-circle/evaluate-womd-interactive-lookahead-n28.txt evaluate --scenes data:womd-interactive \
            --seeds 10 --trust-region 28 --methods safer-in-path-lookahead --ego-contact not-from-behind
        run turning-circle/evaluate-ngsim.txt evaluate --scenes data:commonroad-ngsim --seeds 10 \
            --methods log,safer,safer-in-path
        ten=(--seeds 10 "${along_the_lanes[@]:2}")
        run turning-circle/mutants-womd-interactive-n28-evasive.txt evaluate --scenes data:womd-interactive \
            "${ten[@]}" --planner ../../planners/evasive.yaml --trust-region 28
        run turning-circle/mutants-ngsim-n60-evasive.txt evaluate --scenes data:commonroad-ngsim "${ten[@]}" \
            --planner ../../planners/evasive.yaml --trust-region 60
        # The lane follower under the same settings.
        lane_follower_runs turning-circle ;;
    cut-in-anticipation)
        lane_follower_runs cut-in-anticipation ;;
    bumper)
        mkdir -p bumper
        run bumper/evaluate-ngsim-n60.txt evaluate --scenes data:commonroad-ngsim --seeds 10 --trust-region 60 \
            --methods safer-in-path-lookahead --ego-contact not-from-behind --wrong-way along-the-lanes
        ten=(--seeds 10 "${along_the_lanes[@]:2}")
        run bumper/mutants-womd-interactive-n28-evasive.txt evaluate --scenes data:womd-interactive "${ten[@]}" \
            --planner ../../planners/evasive.yaml --trust-region 28
        run bumper/mutants-ngsim-n60-evasive.txt evaluate --scenes data:commonroad-ngsim "${ten[@]}" \
            --planner ../../planners/evasive.yaml --trust-region 60
        lane_follower_runs bumper ;;
    womd-json-suites)
        mkdir -p womd-json-suites
        ten=(--seeds 10 "${along_the_lanes[@]:2}")
        run womd-json-suites/mutants-womd-json-n28-evasive.txt evaluate --scenes data:womd-json "${ten[@]}" \
            --planner ../../planners/evasive.yaml --trust-region 28
        run womd-json-suites/mutants-womd-json-lane-follower-n60.txt evaluate --scenes data:womd-json \
            "${along_the_lanes_lane_follower[@]}"
        mkdir -p womd-json-suites/ten-seeds
        ten_lane_follower=(--seeds 10 "${along_the_lanes_lane_follower[@]:2}")
        run womd-json-suites/ten-seeds/mutants-womd-json-lane-follower-n60.txt evaluate --scenes data:womd-json \
            "${ten_lane_follower[@]/%log,prior,safer-in-path-lookahead/safer-in-path-lookahead}" ;;
    closed-loop-failures)
        mkdir -p closed-loop-failures
        for s in womd-interactive:womd-interactive:28 womd-json:womd-json:28 commonroad-ngsim:ngsim:60; do
            IFS=: read -r set name n <<<"$s"
            run "closed-loop-failures/evaluate-$name-safer.txt" evaluate --scenes "data:$set" --seeds 10 \
                --stage2-cbv closed-loop --methods log,safer
            run "closed-loop-failures/evaluate-$name-suites.txt" evaluate --scenes "data:$set" --seeds 10 \
                --stage2-cbv closed-loop --background reactive-log-replay --ego-contact not-from-behind \
                --wrong-way along-the-lanes --trust-region "$n" --methods log,safer-in-path-lookahead
        done ;;
    readme-results)
        mkdir -p readme-results
        run readme-results/evaluate-womd-interactive.txt evaluate --scenes data:womd-interactive --seeds 10 \
            --methods safer,safer-in-path,safer-cut-in,safer-in-path-lookahead,safer-distinct,safer-lookahead,safer-inattentive,no-lfr,no-trust-region,prior,log
        run readme-results/evaluate-womd-interactive-default.txt evaluate --scenes data:womd-interactive \
            --seeds 10 --trust-region 28 --methods safer-in-path-lookahead --ego-contact not-from-behind ;;
    closest-approach)
        mkdir -p closest-approach
        for s in "${sets[@]}"; do
            run "closest-approach/evaluate-${s#*:}.txt" evaluate --scenes "data:${s%%:*}" --seeds 10 \
                --methods safer,safer-in-path,safer-in-path-lookahead,no-lfr,no-trust-region,prior
        done ;;
    crossing)
        mkdir -p crossing
        for s in "${sets[@]}"; do
            n=28
            [[ ${s%%:*} == commonroad-ngsim ]] && n=60
            run "crossing/evaluate-${s#*:}.txt" evaluate --scenes "data:${s%%:*}" --seeds 10 --roles crossing \
                --trust-region "$n" --ego-contact not-from-behind --methods log,prior,safer,safer-in-path-lookahead
        done ;;
    crossing-pairings)
        mkdir -p crossing
        reports=$(mktemp -d)
        # The WOMD JSON scenes with a crossing pair (crossing/evaluate-womd-json.txt) that the
        # evaluation keeps (tfrecord-00083-of-01000_389's recorded ego touches another car).
        junctions=2a173b334be3d32c,2bd577a009790706,d1c413df5470bfe6,efc5cbe01b4a526f,tfrecord-00001-of-01000_307
        junctions+=,tfrecord-00072-of-01000_20,tfrecord-00082-of-01000_434,tfrecord-00083-of-01000_455
        junctions+=,tfrecord-00095-of-01000_204,tfrecord-00105-of-01000_241
        ten_lane_follower=(--seeds 10 "${along_the_lanes_lane_follower[@]:2}")
        lookahead_alone=("${ten_lane_follower[@]/%log,prior,safer-in-path-lookahead/safer-in-path-lookahead}")
        for roles in as-loaded crossing; do
            name=mutants-womd-json-lane-follower-n60-$roles
            run "crossing/$name.txt" evaluate --scenes data:womd-json --scene "$junctions" \
                "${lookahead_alone[@]/#as-loaded/$roles}" --json "$reports/$name.json"
            sed -i '/^wrote .*\.json$/d' "crossing/$name.txt"
        done
        python3 scene_kills_union.py "$reports/mutants-womd-json-lane-follower-n60-as-loaded.json" \
            "$reports/mutants-womd-json-lane-follower-n60-crossing.json" >crossing/scene-kills-womd-json-lane-follower.txt
        rm -r "$reports" ;;
    default-sweep)
        mkdir -p default-sweep
        for n in 20 28 40 60 100; do
            run "default-sweep/sweep-n$n.txt" evaluate --scenes data:womd-interactive --seeds 10 \
                --trust-region "$n" --methods safer-in-path-lookahead --ego-contact not-from-behind
        done
        # With any contact: what the rule gives up.
        for n in 20 25 27 28 30 40 60 100; do
            run "default-sweep/any-n$n.txt" evaluate --scenes data:womd-interactive --seeds 10 \
                --trust-region "$n" --methods safer-in-path-lookahead
        done ;;
    esac
done
rm -r "$(dirname "$safer")"
