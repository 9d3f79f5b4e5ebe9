// One control per parameter of the selected object or pair, generated from the schema rows
// (`squish params --json`): slider over the valid range, numeric field, reset to the default,
// `auto` for values the library can derive, and a key at the current frame (the diamond).
const EDITABLE = new Set(['number', 'integer', 'bool']);

// The slider's span for a range with an infinite end: around the default and current value.
function sliderSpan(entry, value) {
  const r = entry.range;
  const finite = (x) => typeof x === 'number' && Number.isFinite(x);
  let min = finite(r.min) ? r.min : Math.min(0, typeof value === 'number' ? value : 0);
  let max = finite(r.max) ? r.max : Math.max(1, 4 * (typeof entry.default === 'number' ? entry.default : 1), 2 * (typeof value === 'number' ? value : 0));
  if (max - min > 1000) max = min + 1000;
  return [min, max];
}

export class ParamPanel {
  constructor(container, send) {
    this.container = container;
    this.send = send;
    this.rows = new Map();
    this.target = null;
    this.onSelectKey = () => {};
  }

  // Builds the rows for `target` ({object: i} or {pair: i}) from the schema.
  build(schema, target) {
    this.target = target;
    this.container.textContent = '';
    this.rows.clear();
    const level = 'object' in target ? 'object' : 'pair';
    for (const entry of schema) {
      if (entry.level !== level || !EDITABLE.has(entry.kind)) continue;
      this.rows.set(entry.key, this.row(entry));
    }
  }

  row(entry) {
    const row = document.createElement('div');
    row.className = 'param';
    row.dataset.key = entry.key;
    row.title = `${entry.key}${entry.symbol ? ` (${entry.symbol}, ${entry.section})` : ''}: ${entry.summary}\nrange ${entry.range?.text ?? '-'}; default ${entry.default}`;
    const name = document.createElement('span');
    name.className = 'name';
    name.textContent = entry.key;
    name.onclick = () => this.onSelectKey(entry.key);
    row.append(name);
    const set = (value, keyframe = false) => this.send({ type: 'set', target: this.target, key: entry.key, value, keyframe });
    const controls = {};
    if (entry.kind === 'bool') {
      const box = document.createElement('input');
      box.type = 'checkbox';
      box.onchange = () => set(box.checked);
      row.append(box, document.createElement('span'));
      controls.box = box;
    } else {
      const slider = document.createElement('input');
      slider.type = 'range';
      slider.step = entry.kind === 'integer' ? '1' : 'any';
      const number = document.createElement('input');
      number.type = 'number';
      number.step = entry.kind === 'integer' ? '1' : 'any';
      slider.oninput = () => {
        number.value = slider.value;
        set(Number(slider.value));
      };
      number.onchange = () => {
        const value = Number(number.value);
        if (number.value.trim() === '' || !Number.isFinite(value)) return;
        set(value);
      };
      row.append(slider, number);
      Object.assign(controls, { slider, number });
    }
    const buttons = document.createElement('span');
    buttons.className = 'buttons';
    const reset = document.createElement('button');
    reset.textContent = '↺';
    reset.title = `reset to the default (${entry.default})`;
    reset.className = 'reset';
    reset.onclick = () => set(entry.default);
    buttons.append(reset);
    if (entry.optional) {
      const auto = document.createElement('button');
      auto.textContent = entry.word;
      auto.title = `let the library derive it: ${entry.auto}`;
      auto.className = 'auto';
      auto.onclick = () => set(entry.word);
      buttons.append(auto);
      controls.auto = auto;
    }
    if (entry.keyframable) {
      const key = document.createElement('button');
      key.textContent = '◆';
      key.className = 'key';
      key.title = 'set a key at the current frame with the current value (on a key: remove it)';
      key.onclick = () => {
        if (key.classList.contains('on')) {
          this.send({ type: 'unkey', target: this.target, key: entry.key });
          return;
        }
        const value = controls.box ? controls.box.checked : Number(controls.number.value);
        set(value, true);
      };
      buttons.append(key);
      controls.key = key;
    }
    row.append(buttons);
    this.container.append(row);
    return { entry, row, controls };
  }

  // Shows the values of the frame (without moving a control the user is dragging).
  update(values, frame) {
    for (const [key, { entry, row, controls }] of this.rows) {
      const shown = values?.[key];
      if (!shown) continue;
      row.classList.toggle('edited', shown.edited);
      const value = shown.value;
      if (controls.box) controls.box.checked = value === true;
      if (controls.slider) {
        const numeric = typeof value === 'number' ? value : null;
        const [min, max] = sliderSpan(entry, numeric);
        controls.slider.min = String(min);
        controls.slider.max = String(max);
        if (document.activeElement !== controls.slider && numeric !== null) controls.slider.value = String(numeric);
        if (document.activeElement !== controls.number) controls.number.value = numeric === null ? '' : String(numeric);
        controls.number.placeholder = typeof value === 'string' ? value : '';
      }
      if (controls.auto) controls.auto.classList.toggle('on', typeof value === 'string');
      if (controls.key) controls.key.classList.toggle('on', shown.keys.includes(frame));
    }
  }
}
