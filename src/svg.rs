//! What the library's SVG pictures share: text escaped for XML, and the colours of the plots'
//! series (a convergence study's and a batch's).

/// Colours of successive series (matplotlib's "tab10", reordered), repeated past the eighth.
pub const PALETTE: [&str; 8] = [
    "#1f77b4", "#d62728", "#2ca02c", "#9467bd", "#ff7f0e", "#8c564b", "#e377c2", "#17becf",
];

/// `s` as XML text or attribute value: `&`, `<`, `>` and `"` escaped.
///
/// ```
/// assert_eq!(sweeping::svg::escape(r#"a < b & "c""#), "a &lt; b &amp; &quot;c&quot;");
/// ```
pub fn escape(s: &str) -> String {
    s.replace('&', "&amp;")
        .replace('<', "&lt;")
        .replace('>', "&gt;")
        .replace('"', "&quot;")
}
