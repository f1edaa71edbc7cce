//! The lexer's word scanner finds exactly the first delimiter, for every byte
//! value, and words are split where a naive split puts them.

use proptest::prelude::*;
use ug::lexer::{Kind, Lexer, word_len};

fn naive(s: &[u8]) -> usize {
    s.iter()
        .position(|&b| {
            matches!(
                b,
                b' ' | b'\t' | b'\n' | b'\r' | 0x0b | 0x0c | b';' | b'(' | b')' | b'{' | b'}'
            )
        })
        .unwrap_or(s.len())
}

#[test]
fn every_byte_value_in_every_position() {
    for b in 0..=255u8 {
        for pos in 0..20 {
            let mut s = vec![b'a'; 20];
            s[pos] = b;
            assert_eq!(word_len(&s), naive(&s), "byte {b:#04x} at {pos}");
            // A word byte before the tested byte in the same chunk.
            s[pos / 2] = b'#';
            assert_eq!(word_len(&s), naive(&s), "byte {b:#04x} at {pos} after '#'");
        }
    }
    assert_eq!(word_len(b""), 0);
    assert_eq!(word_len(b"abc"), 3);
}

proptest! {
    #![proptest_config(ProptestConfig { cases: 20_000, ..ProptestConfig::default() })]

    #[test]
    fn word_len_finds_the_first_delimiter(s in proptest::collection::vec(any::<u8>(), 0..40)) {
        prop_assert_eq!(word_len(&s), naive(&s));
    }

    #[test]
    fn word_len_on_word_like_bytes(s in proptest::collection::vec(prop::sample::select(
        b"az09._#:-'\"{}();, \t\n\x80\xff\x7b\x7d\x29\x2a\x3a\x3c".to_vec()), 0..40)) {
        prop_assert_eq!(word_len(&s), naive(&s));
    }

    #[test]
    fn words_are_split_at_delimiters(s in "[a-z0-9 ;(){}\\n.#é]{0,60}") {
        // Words from the lexer equal those from a naive split (comments aside).
        let src = s.replace(['{', '}'], " ");
        let mut lx = Lexer::new(src.as_bytes(), "t");
        let mut words = Vec::new();
        loop {
            let t = lx.next_token().unwrap();
            match t.kind {
                Kind::Eof => break,
                Kind::Word => words.push(String::from_utf8(t.text.to_vec()).unwrap()),
                _ => {}
            }
        }
        let want: Vec<String> = src
            .split(|c: char| c.is_ascii_whitespace() || "();".contains(c))
            .filter(|w| !w.is_empty())
            .map(str::to_string)
            .collect();
        prop_assert_eq!(words, want);
    }
}
