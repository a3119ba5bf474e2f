//! Unit tests of `scope`.

use super::*;

#[test]
fn forty_four_commands_each_legal_somewhere() {
    assert_eq!(Command::ALL.len(), 44);
    for c in Command::ALL {
        assert!(Scope::ALL.iter().any(|s| legal(*c, *s)), "{}", c.name());
        assert!(c.name().starts_with("vl"));
    }
    assert!(legal(Command::Init, Scope::Uninitialised));
    assert!(!legal(Command::Init, Scope::Library));
    assert!(!legal(Command::StepSize, Scope::Object));
    assert!(legal(Command::Set, Scope::Sample));
    assert!(!legal(Command::Function, Scope::Sample));
}
