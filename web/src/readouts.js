// The readouts of a frame: per object the volume error and largest displacement, per pair the
// contact area and the penetration before and after, and the stage times.
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
    .map(([stage, ms]) => `${stage} ${typeof ms === 'number' ? ms.toFixed(1) : JSON.stringify(ms)}`)
    .join(', ');
  const warnings = frame.warnings.map((w) => `<li>${w}</li>`).join('');
  return `<table><tr><th>object</th><th>volume error</th><th>max displacement</th></tr>${objects}</table>
<table><tr><th>pair</th><th>contact area</th><th>penetration before</th><th>after</th></tr>${pairs}</table>
<p data-testid="times">${frame.edit ? 'fast edit' : 'full frame'}: ${frame.total_ms.toFixed(1)} ms${stages ? ` (${stages})` : ''}</p>
${warnings ? `<ul class="warnings">${warnings}</ul>` : ''}`;
}
