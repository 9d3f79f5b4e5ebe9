// The profile curve editor (§5.4.1): the curve as the server's core evaluated it, its control
// points v0…v5; v2, v3, v4 drag along u (profile_v2…v4, kept in order), v2 also up and down
// (bulge: its ordinate is proportional to γ). Wrinkles show in the curve.
const PAD = 18;
const MIN_V2 = 0.2;
const GAP = 0.005;
// The ordinate the server draws v2 at for bulge = 1 (serve/view.rs DRAWN_BULGE_ORDINATE).
const DRAWN_BULGE_ORDINATE = 0.35;

export class ProfileEditor {
  constructor(canvas, onChange) {
    this.canvas = canvas;
    this.onChange = onChange;
    this.profile = null;
    this.dragging = null;
    canvas.addEventListener('pointerdown', (e) => this.down(e));
    canvas.addEventListener('pointermove', (e) => this.move(e));
    canvas.addEventListener('pointerup', () => { this.dragging = null; });
    canvas.addEventListener('pointerleave', () => { this.dragging = null; });
  }

  range() {
    const ys = [...this.profile.y, ...this.profile.curve.map((p) => p[1])];
    return [Math.min(-1.05, ...ys), Math.max(0.5, ...ys) * 1.1];
  }

  toScreen(u, h) {
    const { width, height } = this.canvas;
    const [lo, hi] = this.range();
    return [PAD + u * (width - 2 * PAD), height - PAD - ((h - lo) / (hi - lo)) * (height - 2 * PAD)];
  }

  fromScreen(x, y) {
    const { width, height } = this.canvas;
    const [lo, hi] = this.range();
    return [(x - PAD) / (width - 2 * PAD), lo + ((height - PAD - y) / (height - 2 * PAD)) * (hi - lo)];
  }

  // The screen position of control point k (for tests and the drawing).
  point(k) {
    return this.toScreen(this.profile.x[k], this.profile.y[k]);
  }

  set(profile) {
    if (this.dragging !== null) return;
    this.profile = profile;
    this.draw();
  }

  draw() {
    const ctx = this.canvas.getContext('2d');
    const { width, height } = this.canvas;
    ctx.clearRect(0, 0, width, height);
    if (!this.profile) return;
    ctx.strokeStyle = '#444';
    ctx.beginPath();
    const [x0, y0] = this.toScreen(0, 0);
    const [x1] = this.toScreen(1, 0);
    ctx.moveTo(x0, y0);
    ctx.lineTo(x1, y0);
    ctx.stroke();
    ctx.strokeStyle = '#666';
    ctx.setLineDash([3, 3]);
    ctx.beginPath();
    this.profile.x.forEach((_, k) => {
      const [x, y] = this.point(k);
      if (k === 0) ctx.moveTo(x, y); else ctx.lineTo(x, y);
    });
    ctx.stroke();
    ctx.setLineDash([]);
    ctx.strokeStyle = '#fc3';
    ctx.lineWidth = 2;
    ctx.beginPath();
    this.profile.curve.forEach(([u, h], i) => {
      const [x, y] = this.toScreen(u, h);
      if (i === 0) ctx.moveTo(x, y); else ctx.lineTo(x, y);
    });
    ctx.stroke();
    ctx.lineWidth = 1;
    this.profile.x.forEach((_, k) => {
      const [x, y] = this.point(k);
      ctx.fillStyle = k >= 2 && k <= 4 ? '#6cf' : '#888';
      ctx.beginPath();
      ctx.arc(x, y, k >= 2 && k <= 4 ? 5 : 3, 0, 2 * Math.PI);
      ctx.fill();
      ctx.fillText(`v${k}`, x + 6, y - 6);
    });
  }

  local(e) {
    const rect = this.canvas.getBoundingClientRect();
    return [((e.clientX - rect.left) * this.canvas.width) / rect.width, ((e.clientY - rect.top) * this.canvas.height) / rect.height];
  }

  down(e) {
    if (!this.profile) return;
    const [x, y] = this.local(e);
    for (const k of [2, 3, 4]) {
      const [px, py] = this.point(k);
      if (Math.hypot(px - x, py - y) < 10) {
        this.dragging = k;
        this.canvas.setPointerCapture(e.pointerId);
        return;
      }
    }
  }

  move(e) {
    if (this.dragging === null) return;
    const k = this.dragging;
    const [x, y] = this.local(e);
    const [u, h] = this.fromScreen(x, y);
    const xs = this.profile.x;
    const lo = k === 2 ? MIN_V2 + GAP : xs[k - 1] + GAP;
    const hi = k === 4 ? 1 - GAP : xs[k + 1] - GAP;
    xs[k] = Math.min(hi, Math.max(lo, u));
    const edits = { [`profile_v${k}`]: Number(xs[k].toFixed(4)) };
    if (k === 2) {
      this.profile.y[2] = Math.max(0, h);
      edits.bulge = Number((this.profile.y[2] / DRAWN_BULGE_ORDINATE).toFixed(4));
    }
    this.draw();
    this.onChange(edits);
  }
}
