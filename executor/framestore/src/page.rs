//! A page's identity, written as its TIFF ImageDescription: `mesopush-frame index=12
//! t_capture_us=400000` (`t_capture_us=` empty when the time is unknown), and the
//! `frames.tif#PAGE` references `frames.csv` uses for stored frames.

use super::STORE_FILE;

/// The prefix of every page description.
const MARKER: &str = "mesopush-frame";

/// Which frame a page holds.
#[derive(Debug, Clone, Copy, PartialEq, Eq)]
pub struct PageMeta {
    /// The frame's row `index` in `frames.csv`.
    pub index: u64,
    /// Its capture time, µs since the trial's start (`frames.csv`'s `t_capture_us`).
    pub t_capture_us: Option<i64>,
}

impl PageMeta {
    /// The ImageDescription text.
    pub fn describe(&self) -> String {
        let t = self.t_capture_us.map_or(String::new(), |t| t.to_string());
        format!("{MARKER} index={} t_capture_us={t}", self.index)
    }

    /// Parses [`Self::describe`]'s text; the error says what is wrong.
    pub fn parse(text: &str) -> Result<Self, String> {
        let text = text.trim_end_matches('\0').trim();
        let mut words = text.split_ascii_whitespace();
        if words.next() != Some(MARKER) {
            return Err(format!("description {text:?} does not start with {MARKER:?}"));
        }
        let (mut index, mut t) = (None, None);
        for w in words {
            let (key, value) =
                w.split_once('=').ok_or_else(|| format!("{w:?} is not key=value"))?;
            match key {
                "index" => index = Some(value.parse::<u64>().map_err(|_| bad(key, value))?),
                "t_capture_us" if value.is_empty() => t = Some(None),
                "t_capture_us" => {
                    t = Some(Some(value.parse::<i64>().map_err(|_| bad(key, value))?))
                }
                _ => {} // later versions may add keys
            }
        }
        let index = index.ok_or_else(|| format!("description {text:?} has no index="))?;
        let t_capture_us = t.ok_or_else(|| format!("description {text:?} has no t_capture_us="))?;
        Ok(Self { index, t_capture_us })
    }
}

fn bad(key: &str, value: &str) -> String {
    format!("{key} = {value:?} is not a whole number")
}

/// `frames.csv`'s name for page `page` of the store: `frames.tif#PAGE`.
pub fn page_ref(page: u64) -> String {
    format!("{STORE_FILE}#{page}")
}

/// The page a `frames.csv` `file` cell names, when it names the store (`frames.tif#PAGE`);
/// `None` for anything else (a PNG path of older trials).
pub fn parse_page_ref(file: &str) -> Option<u64> {
    let (name, page) = file.split_once('#')?;
    if name != STORE_FILE {
        return None;
    }
    page.parse().ok()
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn descriptions_round_trip_and_bad_ones_are_named() {
        for m in [
            PageMeta { index: 7, t_capture_us: Some(-12) },
            PageMeta { index: 0, t_capture_us: None },
        ] {
            assert_eq!(PageMeta::parse(&m.describe()), Ok(m));
        }
        assert!(PageMeta::parse("ImageJ=1.54").unwrap_err().contains("mesopush-frame"));
        assert!(
            PageMeta::parse("mesopush-frame index=x t_capture_us=").unwrap_err().contains("index")
        );
        assert!(PageMeta::parse("mesopush-frame t_capture_us=5").unwrap_err().contains("no index"));
    }

    #[test]
    fn page_refs_name_the_store_only() {
        assert_eq!(parse_page_ref(&page_ref(12)), Some(12));
        assert_eq!(parse_page_ref("frames/000012.png"), None);
        assert_eq!(parse_page_ref("other.tif#3"), None);
        assert_eq!(parse_page_ref("frames.tif#x"), None);
    }
}
