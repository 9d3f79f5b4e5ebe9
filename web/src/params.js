// One control per parameter of the selected object, pair or articulation, generated from the
// schema rows (`squish params --json`): slider over the valid range and numeric field (two fields
// for a pair of numbers, a menu for a choice), reset to the default, `auto` for values the library
// can derive, and a key at the current frame (the diamond). Keys that change nothing for the
// target (`inert`, from the server) are greyed with the reason.
const EDITABLE = new Set(['number', 'integer', 'bool', 'pair', 'choice']);

// The schema level of a target.
export const levelOf = (target) => ('object' in target ? 'object' : 'pair' in target ? 'pair' : 'articulation');

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

  // Builds the rows for `target` ({object: i}, {pair: i} or {articulation: [i, k]}) from the
  // schema; `inert` maps keys that change nothing for it to why.
  build(schema, target, inert = {}) {
    this.target = target;
    this.container.textContent = '';
    this.rows.clear();
    const level = levelOf(target);
    for (const entry of schema) {
      if (entry.level !== level || !EDITABLE.has(entry.kind)) continue;
      const row = this.row(entry);
      if (inert[entry.key]) {
        row.row.classList.add('inert');
        row.row.title = `no effect here: ${inert[entry.key]}\n${row.row.title}`;
      }
      this.rows.set(entry.key, row);
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
    } else if (entry.kind === 'choice') {
      const menu = document.createElement('select');
      for (const choice of entry.choices ?? []) menu.append(new Option(choice, choice));
      menu.onchange = () => set(menu.value);
      row.append(menu, document.createElement('span'));
      controls.menu = menu;
    } else if (entry.kind === 'pair') {
      // Two numbers (an articulation's stiffness of its parent and child sides).
      const fields = [0, 1].map(() => {
        const field = document.createElement('input');
        field.type = 'number';
        field.step = 'any';
        return field;
      });
      const send = () => {
        const values = fields.map((f) => Number(f.value));
        if (fields.some((f) => f.value.trim() === '') || !values.every(Number.isFinite)) return;
        set(values);
      };
      for (const field of fields) field.onchange = send;
      row.append(...fields);
      controls.pair = fields;
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
        const value = controls.box ? controls.box.checked
          : controls.menu ? controls.menu.value
          : controls.pair ? controls.pair.map((f) => Number(f.value))
          : Number(controls.number.value);
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
      if (controls.menu && document.activeElement !== controls.menu) controls.menu.value = String(value);
      if (controls.pair) {
        const pair = Array.isArray(value) ? value : [value, value];
        controls.pair.forEach((f, k) => { if (document.activeElement !== f) f.value = String(pair[k]); });
      }
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
