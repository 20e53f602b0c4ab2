//! Closed sets of names a user picks from — an agent preset, a renderer, a reward, a task —
//! declared once, on the library's enum ([`Vocabulary::TERMS`]): the command line's flags
//! take their values, help and error from it, the Python bindings parse their keyword
//! arguments with it, and files name values with it. No front door spells the names again.

/// One name of a vocabulary.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct Term<T: 'static> {
    /// The value.
    pub value: T,
    /// Its name (on the command line, in Python, in files).
    pub name: &'static str,
    /// Other names accepted for it (old spellings).
    pub aliases: &'static [&'static str],
    /// One line for `--help`.
    pub help: &'static str,
}

/// A name that is not one of its vocabulary's: says what was given and what is known.
#[derive(Debug, Clone, PartialEq, Eq, thiserror::Error)]
#[error("unknown {what} `{given}` ({})", known.join(", "))]
pub struct UnknownName {
    /// What kind of name (`reward`, `renderer`, …).
    pub what: &'static str,
    /// The text given.
    pub given: String,
    /// The names known, in order.
    pub known: Vec<&'static str>,
}

impl From<UnknownName> for crate::invalid::Invalid {
    fn from(e: UnknownName) -> Self {
        e.to_string().into()
    }
}

/// A closed set of named values.
pub trait Vocabulary: Copy + PartialEq + Sized + 'static {
    /// What a value is called in messages (`reward`, `agent preset`).
    const WHAT: &'static str;
    /// Every value with its name, aliases and help, in the order users see them.
    const TERMS: &'static [Term<Self>];

    /// The value's name.
    fn term_name(self) -> &'static str {
        Self::TERMS
            .iter()
            .find(|t| t.value == self)
            .map_or("", |t| t.name)
    }

    /// The value named `text` (a name or an alias).
    fn parse_name(text: &str) -> Result<Self, UnknownName> {
        Self::TERMS
            .iter()
            .find(|t| t.name == text || t.aliases.contains(&text))
            .map(|t| t.value)
            .ok_or_else(|| UnknownName {
                what: Self::WHAT,
                given: text.to_string(),
                known: Self::names(),
            })
    }

    /// Every name, in order.
    fn names() -> Vec<&'static str> {
        Self::TERMS.iter().map(|t| t.name).collect()
    }
}

/// Gives vocabularies `Display` (the name) and `FromStr` (a name or an alias, else
/// [`UnknownName`]), both read from [`Vocabulary::TERMS`]: write it after each
/// `impl Vocabulary`, so `format!("{x}")`, `.parse()` and clap all spell the one table.
macro_rules! name_traits {
    ($($t:ty),+ $(,)?) => {$(
        impl ::std::fmt::Display for $t {
            fn fmt(&self, f: &mut ::std::fmt::Formatter<'_>) -> ::std::fmt::Result {
                f.pad($crate::vocab::Vocabulary::term_name(*self))
            }
        }

        impl ::std::str::FromStr for $t {
            type Err = $crate::vocab::UnknownName;

            fn from_str(text: &str) -> Result<Self, Self::Err> {
                <$t as $crate::vocab::Vocabulary>::parse_name(text)
            }
        }
    )+};
}
pub(crate) use name_traits;

#[cfg(test)]
mod tests {
    use super::*;

    #[derive(Debug, Clone, Copy, PartialEq)]
    enum Fruit {
        Apple,
        Pear,
    }

    impl Vocabulary for Fruit {
        const WHAT: &'static str = "fruit";
        const TERMS: &'static [Term<Self>] = &[
            Term {
                value: Fruit::Apple,
                name: "apple",
                aliases: &["malus"],
                help: "red",
            },
            Term {
                value: Fruit::Pear,
                name: "pear",
                aliases: &[],
                help: "green",
            },
        ];
    }

    #[test]
    fn names_parse_aliases_count_and_unknown_names_list_the_known() {
        assert_eq!(Fruit::parse_name("pear"), Ok(Fruit::Pear));
        assert_eq!(Fruit::parse_name("malus"), Ok(Fruit::Apple));
        assert_eq!(Fruit::Apple.term_name(), "apple");
        let e = Fruit::parse_name("plum").unwrap_err();
        assert_eq!(e.to_string(), "unknown fruit `plum` (apple, pear)");
        assert_eq!(Fruit::names(), vec!["apple", "pear"]);
    }

    name_traits!(Fruit);

    #[test]
    fn display_and_from_str_read_the_table() {
        assert_eq!(Fruit::Pear.to_string(), "pear");
        assert_eq!(format!("{:>6}|", Fruit::Apple), " apple|");
        assert_eq!("malus".parse::<Fruit>(), Ok(Fruit::Apple));
        let e = "Pear".parse::<Fruit>().unwrap_err();
        assert_eq!(e.given, "Pear");
        assert_eq!(e.known, vec!["apple", "pear"]);
    }
}
