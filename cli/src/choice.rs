//! Command-line choices among the library's enums. The library names its
//! variants through serde (kebab-case, as the specs spell them, read by
//! `spec_name`) and lists them in `ALL`; this adapter turns such a list into a clap value parser,
//! so that the library carries no command-line trait.

use clap::builder::{PossibleValuesParser, TypedValueParser};
use safer_scenarios::spec::spec_name as name_of;

/// A clap value parser accepting the serde names of `all`.
pub(crate) fn choice<T>(all: &'static [T]) -> impl TypedValueParser<Value = T>
where
    T: serde::Serialize + Copy + Send + Sync + 'static,
{
    let names: Vec<String> = all.iter().map(name_of).collect();
    PossibleValuesParser::new(names.clone()).map(move |name| {
        // The parser admitted only these names.
        all[names.iter().position(|n| *n == name).unwrap_or_default()]
    })
}

#[cfg(test)]
mod tests {
    use super::*;
    use safer_scenarios::spec::suite::AdversaryMethod;

    #[test]
    fn every_library_choice_names_its_variants_as_the_specs_do() {
        assert_eq!(name_of(&AdversaryMethod::SaferLookahead), "safer-lookahead");
        assert_eq!(name_of(&safer_scenarios::datasets::held_out::Split::HeldOut), "held-out");
        for all in [
            AdversaryMethod::ALL.iter().map(name_of).collect::<Vec<_>>(),
            safer_scenarios::spec::suite::Stage2Cbv::ALL.iter().map(name_of).collect(),
            safer_scenarios::policies::adversary::ApproachPhase::ALL.iter().map(name_of).collect(),
            safer_scenarios::spec::SpecKind::ALL.iter().map(name_of).collect(),
            safer_scenarios::harness::methods::BackgroundDriver::ALL.iter().map(name_of).collect(),
            safer_scenarios::policies::BackgroundPolicy::ALL.iter().map(name_of).collect(),
            safer_scenarios::eval::witness::RoadKeeping::ALL.iter().map(name_of).collect(),
            safer_scenarios::planners::BuiltinPlanner::ALL.iter().map(name_of).collect(),
            safer_scenarios::harness::evaluation::ArtefactVariants::ALL.iter().map(name_of).collect(),
        ] {
            let mut unique = all.clone();
            unique.sort();
            unique.dedup();
            assert_eq!(unique.len(), all.len(), "{all:?}");
        }
    }

    #[test]
    fn a_choice_parses_its_names_and_refuses_others() {
        use clap::Parser;
        #[derive(Parser)]
        struct Args {
            #[arg(long, value_parser = choice(AdversaryMethod::ALL), value_delimiter = ',')]
            methods: Vec<AdversaryMethod>,
        }
        let args = Args::try_parse_from(["x", "--methods", "safer,no-lfr,log"]).expect("valid names");
        assert_eq!(args.methods, [AdversaryMethod::Safer, AdversaryMethod::NoLfr, AdversaryMethod::Log]);
        let err = Args::try_parse_from(["x", "--methods", "saffer"]).err().expect("a typo is refused").to_string();
        assert!(err.contains("saffer") && err.contains("safer-lookahead"), "{err}");
    }
}
