// The robot's state in the top bar: battery, charging and localization quality from
// robot_basic_state, and whether the robot is connected, from /diagnostics_agg (the status
// whose name mentions "connection"); on a fleet server, of the robot chosen in the fleet panel,
// whose name the robot pill shows (currentrobot.js).
import { CurrentRobot } from './currentrobot.js';
import { log } from './log.js';
import { TOPICS } from './names.js';

const LEVELS = ['ok', 'warn', 'error', 'stale'];
const STALE_MS = 5000;
export const QUALITY_LOW = 50; // where /diagnostics_agg's Localization turns WARN

function meter(id, percent, text, state) {
  const box = document.getElementById(id);
  const p = Math.max(0, Math.min(100, percent));
  box.querySelector('.fill').style.width = `${p}%`;
  box.querySelector('.value').textContent = text;
  box.dataset.state = state;
}

export class RobotState {
  constructor({ stores, robot = new CurrentRobot() }) {
    this.robotPill = document.getElementById('robot-state');
    this.robot = robot;
    this.lastDiagnostics = 0;
    stores.follow(robot, TOPICS.robotBasicState, (s) => this.basic(s), () => this.forget());
    stores.follow(robot, TOPICS.diagnostics, (d) => this.diagnostics(d));
    setInterval(() => {
      // robotpresence.js says so, or app.js's followReplay
      if (document.body.classList.contains('no-robot') || document.body.classList.contains('replaying')) return;
      if (this.lastDiagnostics && Date.now() - this.lastDiagnostics > STALE_MS) {
        this.setRobot('stale', 'no diagnostics');
      }
    }, 1000);
  }

  /** Another robot was chosen: nothing is known of it until it speaks. */
  forget() {
    meter('battery', 0, '–', 'unknown');
    meter('localization', 0, '–', 'unknown');
    this.lastDiagnostics = 0;
    this.setRobot('unknown', 'waiting…');
  }

  basic(s) {
    const b = s.battery_percentage;
    const charge = s.is_charging ? ' ⚡ charging' : s.is_dc_in ? ' · on dock' : '';
    meter('battery', b, `${b}%${charge}`, b < 15 ? 'low' : s.is_charging ? 'charging' : 'ok');
    const q = s.localization_quality;
    const mapping = s.is_map_building_enabled ? ' · mapping' : '';
    meter('localization', q, `${q}${mapping}`, q < QUALITY_LOW ? 'low' : q < 60 ? 'fair' : 'ok');
    // the Robot panel
    const chargeBox = document.getElementById('charge-state');
    const chargeState = s.is_charging ? 'charging' : s.is_dc_in ? 'docked' : 'discharging';
    chargeBox.dataset.state = chargeState;
    chargeBox.textContent = { charging: `⚡ charging · ${b}%`, docked: `on the dock · ${b}%`,
      discharging: `on battery · ${b}%` }[chargeState];
    const loc = document.getElementById('loc-state');
    const low = s.is_localization_enabled && q < QUALITY_LOW;
    loc.dataset.state = low ? 'low' : 'ok';
    loc.textContent = s.is_localization_enabled ? `localization ${q}` : 'localization off';
    const warning = document.getElementById('loc-warning');
    if (low && warning.hidden) log('warning', `localization quality is low (${q}): relocalize the robot`);
    warning.hidden = !low;
  }

  diagnostics(array) {
    const statuses = (array && array.status) || [];
    const conn = statuses.find((s) => /connection/i.test(s.name || ''));
    if (!conn || document.body.classList.contains('replaying')) return; // a recorded link, not live
    this.lastDiagnostics = Date.now();
    const level = LEVELS[conn.level] || 'error';
    const text = level === 'ok' ? (conn.message || 'connected') : conn.message || level;
    this.setRobot(level, text);
    this.robotPill.title = `${conn.name}: ${conn.message || ''}`;
  }

  setRobot(state, text) {
    this.robotPill.dataset.state = state;
    this.robotPill.dataset.robot = this.robot.name || '';
    this.robotPill.querySelector('.value').textContent = this.robot.name ? `${this.robot.name} · ${text}` : text;
  }
}
