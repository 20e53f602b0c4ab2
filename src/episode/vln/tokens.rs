//! Instruction tokens and the vocabulary of the VLN-CE export.
//!
//! Tokenisation is R2R's (the Matterport3D simulator's `Tokenizer`, which VLN-CE's files were
//! made with): lower case, split at runs of characters that are not word characters
//! (`[^A-Za-z0-9_]`, as Python's `\W` for ASCII text); a run of only full stops is one token,
//! other punctuation runs give one token per character; white space is dropped.
//!
//! The vocabulary lists `<pad>`, `<unk>`, `<s>`, `</s>` (habitat-lab's `VocabDict` tokens,
//! so its `PAD_INDEX` is 0 and `UNK_INDEX` 1) and then every token of the exported
//! instructions in sorted order. Token lists are padded with 0 to [`TOKENS_PER_INSTRUCTION`], as
//! VLN-CE's are.

use std::collections::{BTreeMap, BTreeSet};

/// Length of every `instruction_tokens` list (VLN-CE pads to 200).
pub const TOKENS_PER_INSTRUCTION: usize = 200;

/// The special tokens at the head of the vocabulary, in order.
pub const SPECIAL_TOKENS: [&str; 4] = ["<pad>", "<unk>", "<s>", "</s>"];

/// R2R's tokens of `text` (see the module documentation).
pub fn tokenize(text: &str) -> Vec<String> {
    let lower = text.to_lowercase();
    let mut out = Vec::new();
    let mut word = String::new();
    let mut punct = String::new();
    let flush_punct = |punct: &mut String, out: &mut Vec<String>| {
        let p: String = punct.chars().filter(|c| !c.is_whitespace()).collect();
        if !p.is_empty() {
            if p.chars().all(|c| c == '.') {
                out.push(p);
            } else {
                out.extend(p.chars().map(String::from));
            }
        }
        punct.clear();
    };
    for c in lower.chars() {
        if c.is_ascii_alphanumeric() || c == '_' {
            flush_punct(&mut punct, &mut out);
            word.push(c);
        } else {
            if !word.is_empty() {
                out.push(std::mem::take(&mut word));
            }
            punct.push(c);
        }
    }
    if !word.is_empty() {
        out.push(word);
    }
    flush_punct(&mut punct, &mut out);
    out
}

/// A vocabulary: the special tokens, then sorted words.
#[derive(Debug, Clone, PartialEq, Eq)]
pub struct Vocabulary {
    /// Every token, by index.
    pub words: Vec<String>,
    index: BTreeMap<String, u32>,
}

impl Vocabulary {
    /// The vocabulary of `texts`.
    pub fn of<'a>(texts: impl IntoIterator<Item = &'a str>) -> Self {
        let mut set = BTreeSet::new();
        for t in texts {
            set.extend(tokenize(t));
        }
        let words: Vec<String> = SPECIAL_TOKENS
            .iter()
            .map(|s| s.to_string())
            .chain(
                set.into_iter()
                    .filter(|w| !SPECIAL_TOKENS.contains(&w.as_str())),
            )
            .collect();
        let index = words
            .iter()
            .enumerate()
            .map(|(i, w)| (w.clone(), i as u32))
            .collect();
        Vocabulary { words, index }
    }

    /// The padded token indices of `text` (unknown words are `<unk>`, 1).
    pub fn encode(&self, text: &str) -> Vec<u32> {
        let mut ids: Vec<u32> = tokenize(text)
            .iter()
            .map(|w| self.index.get(w).copied().unwrap_or(1))
            .take(TOKENS_PER_INSTRUCTION)
            .collect();
        ids.resize(TOKENS_PER_INSTRUCTION, 0);
        ids
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn tokens_follow_r2r() {
        assert_eq!(
            tokenize("Walk past the sofa, then stop next to the coffee_table..."),
            [
                "walk",
                "past",
                "the",
                "sofa",
                ",",
                "then",
                "stop",
                "next",
                "to",
                "the",
                "coffee_table",
                "..."
            ]
        );
        assert_eq!(
            tokenize("Go up. Stop!?"),
            ["go", "up", ".", "stop", "!", "?"]
        );
    }

    #[test]
    fn vocabulary_starts_with_the_special_tokens_and_pads_with_zero() {
        let v = Vocabulary::of(["Turn left.", "Turn right and stop."]);
        assert_eq!(
            v.words,
            ["<pad>", "<unk>", "<s>", "</s>", ".", "and", "left", "right", "stop", "turn"]
        );
        let ids = v.encode("Turn left, stop.");
        assert_eq!(&ids[..5], &[9, 6, 1, 8, 4]);
        assert_eq!(ids.len(), TOKENS_PER_INSTRUCTION);
        assert!(ids[5..].iter().all(|&i| i == 0));
    }
}
