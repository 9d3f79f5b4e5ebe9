// The WebSocket to the server: messages out, frames and errors in; reconnects when dropped.
export class Connection {
  constructor(onMessage, onStatus) {
    this.onMessage = onMessage;
    this.onStatus = onStatus;
    this.open();
  }

  open() {
    const url = new URL('api/ws', window.location.href);
    url.protocol = url.protocol === 'https:' ? 'wss:' : 'ws:';
    this.socket = new WebSocket(url);
    this.socket.onopen = () => this.onStatus('connected');
    this.socket.onclose = () => {
      this.onStatus('disconnected: retrying');
      setTimeout(() => this.open(), 1000);
    };
    this.socket.onmessage = (event) => {
      let message;
      try {
        message = JSON.parse(event.data);
      } catch (e) {
        message = { type: 'error', message: `unreadable message from the server: ${e}` };
      }
      this.onMessage(message);
    };
  }

  send(message) {
    if (this.socket.readyState === WebSocket.OPEN) this.socket.send(JSON.stringify(message));
  }
}
