//! report.md: the table of every case's measures against their references, then per case its
//! measures' sources and tolerances and its chart.
use super::*;

/// report.md: the table, then per case its measures' sources and tolerances and its chart.
pub(super) fn report_md(
    o: &ValidateOptions,
    cases: &[(String, CaseDef)],
    rows: &[Row],
    skipped: &[String],
    charts: &[String],
) -> String {
    let mut s = String::from("# Validation report\n\n");
    let failed = rows.iter().filter(|r| r.failed()).count();
    let judged = rows.iter().filter(|r| r.allowed.is_some()).count();
    let _ = writeln!(
        s,
        "`tdyn validate{}{} --np {}`: {} of {judged} judged measures pass{}.\n",
        if o.fast { " --fast" } else { "" },
        if o.cases.is_empty() {
            String::new()
        } else {
            format!(" --cases {}", o.cases.join(","))
        },
        o.np,
        judged - failed,
        if skipped.is_empty() {
            String::new()
        } else {
            format!("; not run under --fast: {}", skipped.join(", "))
        }
    );
    s.push_str("| case | resolution | measure | ours | reference | error | allowed | result |\n");
    s.push_str("| --- | --- | --- | --- | --- | --- | --- | --- |\n");
    for r in rows {
        let reference = if r.band[0] != r.band[1] {
            format!(
                "{} ({} - {})",
                num(r.reference),
                num(r.band[0]),
                num(r.band[1])
            )
        } else {
            num(r.reference)
        };
        let error = if !r.error.is_finite() {
            "-".into()
        } else if r.reference != 0.0 {
            format!("{} %", num(100.0 * r.error))
        } else {
            num(r.error)
        };
        let _ = writeln!(
            s,
            "| {} | {} | {} | {} | {} {} | {error} | {} | {} |",
            r.case,
            r.rung,
            r.measure,
            num(r.ours),
            reference,
            r.unit,
            allowed_text(r.allowed, &r.unit),
            r.status
        );
    }
    let messages: Vec<&Row> = rows.iter().filter(|r| !r.message.is_empty()).collect();
    if !messages.is_empty() {
        s.push_str("\n## Runs that failed\n\n");
        let mut seen = Vec::new();
        for r in messages {
            let key = format!("{} {}", r.case, r.rung);
            if seen.contains(&key) {
                continue;
            }
            let _ = writeln!(s, "- {key}:\n\n```\n{}\n```", r.message.trim());
            seen.push(key);
        }
    }
    for (name, case) in cases {
        if skipped.contains(name) {
            continue;
        }
        let _ = writeln!(s, "\n## {name}: {}\n", case.title);
        if charts.contains(name) {
            let _ = writeln!(s, "![{name}]({name}.png)\n");
        }
        for m in &case.measure {
            let _ = writeln!(
                s,
                "- **{}** ({}): {}. Tolerance: {}",
                m.name,
                m.what(),
                m.source.trim(),
                m.why.trim()
            );
        }
    }
    s
}
