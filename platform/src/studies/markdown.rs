//! Researcher-written text (consent form, instructions) from Markdown to HTML that is safe to put
//! in a page: raw HTML is shown as text, never interpreted (ethics boards ask for the consent
//! text as written; a `<script>` in it must neither run nor vanish silently), links keep only
//! `http:`, `https:` and `mailto:` addresses, and images only show library items
//! (`![caption](item:NAME)`, NAME being the item's name in the study's library) — the pages'
//! Content-Security-Policy would block any other image anyway.

use pulldown_cmark::{CowStr, Event, LinkType, Options, Parser, Tag, TagEnd, html};

/// Largest Markdown text a study setting may hold.
pub const MAX_MARKDOWN_CHARS: usize = 20_000;

/// Renders `text` to HTML. `item_url` maps an item name to its image address (`None`: no such
/// item; the image is replaced by its caption in brackets).
pub fn to_html(text: &str, item_url: &dyn Fn(&str) -> Option<String>) -> String {
    let options = Options::ENABLE_TABLES | Options::ENABLE_STRIKETHROUGH;
    let mut events = Vec::new();
    // Inside a dropped link or image: the tag's end must be dropped too.
    let mut dropped: Vec<bool> = Vec::new();
    let mut in_image: Vec<bool> = Vec::new();
    for event in Parser::new_ext(text, options) {
        match event {
            Event::Html(raw) | Event::InlineHtml(raw) => events.push(Event::Text(raw)),
            Event::Start(Tag::Link {
                link_type,
                dest_url,
                title,
                id,
            }) => {
                let keep = safe_link(&dest_url);
                dropped.push(!keep);
                if keep {
                    events.push(Event::Start(Tag::Link {
                        link_type,
                        dest_url,
                        title,
                        id,
                    }));
                }
            }
            Event::End(TagEnd::Link) => {
                if !dropped.pop().unwrap_or(false) {
                    events.push(Event::End(TagEnd::Link));
                }
            }
            Event::Start(Tag::Image {
                dest_url,
                title,
                id,
                ..
            }) => {
                let url = dest_url
                    .strip_prefix("item:")
                    .and_then(|name| item_url(name.trim()));
                in_image.push(url.is_none());
                match url {
                    Some(url) => events.push(Event::Start(Tag::Image {
                        link_type: LinkType::Inline,
                        dest_url: CowStr::from(url),
                        title,
                        id,
                    })),
                    None => events.push(Event::Text("[".into())),
                }
            }
            Event::End(TagEnd::Image) => {
                if in_image.pop().unwrap_or(false) {
                    events.push(Event::Text("]".into()));
                } else {
                    events.push(Event::End(TagEnd::Image));
                }
            }
            other => events.push(other),
        }
    }
    let mut out = String::with_capacity(text.len() * 3 / 2);
    html::push_html(&mut out, events.into_iter());
    out
}

/// Whether a link address may be followed: web and mail addresses, and paths on this site.
fn safe_link(url: &str) -> bool {
    let lower = url.trim().to_ascii_lowercase();
    lower.starts_with("https://")
        || lower.starts_with("http://")
        || lower.starts_with("mailto:")
        || (lower.starts_with('/') && !lower.starts_with("//"))
        || lower.starts_with('#')
}

/// The `item:` names a Markdown text refers to, for validation when the text is saved.
pub fn item_references(text: &str) -> Vec<String> {
    Parser::new_ext(text, Options::empty())
        .filter_map(|e| match e {
            Event::Start(Tag::Image { dest_url, .. }) => {
                dest_url.strip_prefix("item:").map(|n| n.trim().to_string())
            }
            _ => None,
        })
        .collect()
}

#[cfg(test)]
mod tests {
    use super::*;

    fn items(name: &str) -> Option<String> {
        (name == "noto/dog.svg").then(|| "/media/items/7.png".to_string())
    }

    #[test]
    fn formatting_is_rendered() {
        let html = to_html(
            "# Title\n\nSome **bold** and *italic*.\n\n- one\n- two\n",
            &items,
        );
        assert!(html.contains("<h1>Title</h1>"), "{html}");
        assert!(html.contains("<strong>bold</strong>"), "{html}");
        assert!(html.contains("<li>one</li>"), "{html}");
    }

    #[test]
    fn raw_html_is_shown_as_text() {
        let html = to_html(
            "Hello <script>alert(1)</script>\n\n<div onclick=\"x()\">block</div>\n",
            &items,
        );
        assert!(!html.contains("<script"), "{html}");
        assert!(!html.contains("<div"), "{html}");
        assert!(
            html.contains("&lt;script&gt;alert(1)&lt;/script&gt;"),
            "{html}"
        );
        assert!(html.contains("&lt;div onclick="), "{html}");
    }

    #[test]
    fn only_safe_links_and_item_images_survive() {
        let html = to_html(
            "[ok](https://example.org/x) [bad](javascript:alert(1)) [mail](mailto:a@b.c) \
             ![dog](item:noto/dog.svg) ![remote](https://evil.example/x.png) \
             ![missing](item:nope.svg)",
            &items,
        );
        assert!(
            html.contains("<a href=\"https://example.org/x\">ok</a>"),
            "{html}"
        );
        assert!(!html.contains("javascript"), "{html}");
        assert!(html.contains(">bad<") || html.contains(" bad "), "{html}");
        assert!(html.contains("href=\"mailto:a@b.c\""), "{html}");
        assert!(
            html.contains("<img src=\"/media/items/7.png\" alt=\"dog\""),
            "{html}"
        );
        assert!(!html.contains("evil.example"), "{html}");
        assert!(
            html.contains("[remote]") && html.contains("[missing]"),
            "{html}"
        );
    }

    #[test]
    fn item_references_are_listed() {
        assert_eq!(
            item_references("![a](item:x.svg) ![b](https://e/x.png) ![c](item:y.svg)"),
            vec!["x.svg".to_string(), "y.svg".to_string()]
        );
    }
}
