// The readouts of a frame: per object the volume error and largest displacement, per pair the
// contact area and the penetration before and after, per articulation (self-contact) whether it
// is in contact and its self-intersecting faces before and after, and the stage times (those
// that took any: self-contact runs before the contact stages).
const fmt = (x, digits = 3) => (x === null || x === undefined ? '–' : Number(x).toPrecision(digits));
const pct = (x) => (x === null || x === undefined ? '–' : `${(100 * x).toPrecision(2)}%`);

export function readouts(frame) {
  const objects = frame.objects
    .map((o) => `<tr><td>${o.name}</td><td data-testid="volume-${o.name}">${pct(o.quality.relative_volume_change)}</td><td>${fmt(o.quality.max_deformation)}</td></tr>`)
    .join('');
  const pairs = frame.pairs
    .map((p) => `<tr><td>${p.objects.join(' × ')}</td><td>${fmt(p.contact_area)}</td><td>${fmt(p.penetration_before)}</td><td data-testid="penetration-after">${fmt(p.penetration_after)}</td></tr>`)
    .join('');
  const stages = Object.entries(frame.stages ?? {})
    .filter(([, ms]) => typeof ms !== 'number' || ms >= 0.05)
    .map(([stage, ms]) => `${stage} ${typeof ms === 'number' ? ms.toFixed(1) : JSON.stringify(ms)}`)
    .join(', ');
  const articulations = (frame.articulations ?? [])
    .map((a) => `<tr><td>${a.name}</td><td>${a.error ? `inactive: ${a.error}` : a.in_contact ? 'contact' : '–'}</td><td>${a.faces_before} → ${a.faces_after}</td><td>${a.time_ms.toFixed(1)}</td></tr>`)
    .join('');
  const warnings = frame.warnings.map((w) => `<li>${w}</li>`).join('');
  return `<table><tr><th>object</th><th>volume error</th><th>max displacement</th></tr>${objects}</table>
${pairs ? `<table><tr><th>pair</th><th>contact area</th><th>penetration before</th><th>after</th></tr>${pairs}</table>` : ''}
${articulations ? `<table data-testid="articulations"><tr><th>articulation</th><th></th><th>faces crossing</th><th>ms</th></tr>${articulations}</table>` : ''}
<p data-testid="times">${frame.edit ? 'fast edit' : 'full frame'}: ${frame.total_ms.toFixed(1)} ms${stages ? ` (${stages})` : ''}</p>
${warnings ? `<ul class="warnings">${warnings}</ul>` : ''}`;
}
