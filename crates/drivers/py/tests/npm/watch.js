// A viewer written with npm's @foxglove/ws-protocol client (its default subprotocol,
// foxglove.websocket.v1, as Lichtblick uses it): subscribes to the topics named on the command
// line and prints one JSON line per topic once each has sent a message, then closes.
const { FoxgloveClient } = require("@foxglove/ws-protocol");
const WebSocket = require("ws");

const [url, ...topics] = process.argv.slice(2);
const ws = new WebSocket(url, [FoxgloveClient.SUPPORTED_SUBPROTOCOL]);
const client = new FoxgloveClient({ ws });
const byTopic = new Map();
const got = new Map();
let info = null;
client.on("serverInfo", (m) => { info = m; });
client.on("advertise", (channels) => {
  for (const ch of channels) {
    if (topics.includes(ch.topic) && ![...byTopic.values()].includes(ch.topic)) {
      byTopic.set(client.subscribe(ch.id), ch.topic);
    }
  }
});
client.on("message", ({ subscriptionId, timestamp, data }) => {
  const topic = byTopic.get(subscriptionId);
  if (topic !== undefined && !got.has(topic)) {
    got.set(topic, { timestamp: timestamp.toString(), bytes: data.byteLength });
  }
  if (got.size === topics.length) {
    console.log(JSON.stringify({ subprotocol: ws.protocol, server: info && info.name,
                                 got: Object.fromEntries(got) }));
    client.close();
    setTimeout(() => process.exit(0), 200);
  }
});
client.on("error", (e) => { console.error(String(e)); process.exit(1); });
setTimeout(() => { console.error("timed out"); process.exit(2); }, 30000);
