//! The nearest known name to a misspelt one, for messages that suggest it (scene fields and
//! variants, command-line words).

/// The name of `known` nearest `word` by edit distance, when at most about a third of its
/// letters differ.
#[must_use]
pub fn nearest<'a>(word: &str, known: &[&'a str]) -> Option<&'a str> {
    known
        .iter()
        .map(|k| (edit_distance(word, k), *k))
        .min_by_key(|(d, _)| *d)
        .filter(|(d, _)| *d <= word.chars().count().max(3) / 3 + 1)
        .map(|(_, k)| k)
}

/// Levenshtein distance between `a` and `b`, in characters.
#[must_use]
pub fn edit_distance(a: &str, b: &str) -> usize {
    let b: Vec<char> = b.chars().collect();
    let mut row: Vec<usize> = (0..=b.len()).collect();
    for (i, ca) in a.chars().enumerate() {
        let mut diagonal = row[0];
        row[0] = i + 1;
        for (j, cb) in b.iter().enumerate() {
            let above = row[j + 1];
            row[j + 1] = (above + 1)
                .min(row[j] + 1)
                .min(diagonal + usize::from(ca != *cb));
            diagonal = above;
        }
    }
    row[b.len()]
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn misspellings_find_their_name_and_strangers_none() {
        let known = ["isovalue", "groups", "blend", "camera", "lights", "version"];
        assert_eq!(nearest("isovalu", &known), Some("isovalue"));
        assert_eq!(nearest("blnd", &known), Some("blend"));
        assert_eq!(nearest("grups", &known), Some("groups"));
        assert_eq!(nearest("frobnicate", &known), None);
        assert_eq!(edit_distance("kitten", "sitting"), 3);
    }
}
