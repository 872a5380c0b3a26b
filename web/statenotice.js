// Says once in the Messages panel, when the page first hears from the server, where the
// robot's state came from: "state restored from …" (with what came back) or "started fresh
// in …". The server reports it in the /Bridge/State entry of /diagnostics_agg.
/* global ROSLIB */
import { log } from './log.js';
import { DIAGNOSTICS, TOPICS } from './names.js';

export function showStateOnce(ros) {
  const topic = new ROSLIB.Topic({
    ros, name: TOPICS.diagnostics, messageType: 'diagnostic_msgs/DiagnosticArray',
  });
  const onMessage = (msg) => {
    const item = msg.status.find((s) => s.name === DIAGNOSTICS.bridgeState);
    if (!item) return;
    topic.unsubscribe(onMessage);
    const restored = item.values.find((v) => v.key === 'restored');
    const text = restored && restored.value !== 'nothing'
      ? `${item.message}: ${restored.value}` : item.message;
    log('info', text);  // the Messages panel; no toast: toasts are for what went wrong
  };
  topic.subscribe(onMessage);
}
