"""An independent reader of Petrel recordings (the Python `mcap` package).

Usage: python3 read_mcap.py FILE.mcap
Prints JSON: for each channel its message encoding, schema name and
encoding, and message count as read; the number of JSON messages or JSON
schemas that failed to parse; whether the summary's statistics agree with
the counts read; the header's profile; the first /petrel/inputs message.
"""

import json
import sys

from mcap.reader import make_reader


def main(path):
    channels = {}
    json_errors = 0
    first_input = None
    with open(path, "rb") as f:
        reader = make_reader(f)
        header = reader.get_header()
        for schema, channel, message in reader.iter_messages():
            c = channels.setdefault(
                channel.topic,
                {
                    "message_encoding": channel.message_encoding,
                    "schema": schema.name if schema else None,
                    "schema_encoding": schema.encoding if schema else None,
                    "count": 0,
                },
            )
            c["count"] += 1
            if c["count"] == 1 and schema and schema.encoding == "jsonschema":
                try:
                    json.loads(schema.data)
                except ValueError:
                    json_errors += 1
            if channel.message_encoding == "json":
                try:
                    value = json.loads(message.data)
                except ValueError:
                    json_errors += 1
                    continue
                if channel.topic == "/petrel/inputs" and first_input is None:
                    first_input = value
            if message.log_time != message.publish_time:
                json_errors += 1
        summary = reader.get_summary()
        matches = summary is not None and summary.statistics is not None
        if matches:
            for cid, n in summary.statistics.channel_message_counts.items():
                topic = summary.channels[cid].topic
                if channels.get(topic, {}).get("count") != n:
                    matches = False
    json.dump(
        {
            "channels": channels,
            "json_errors": json_errors,
            "summary_matches": matches,
            "profile": header.profile,
            "first_input": first_input,
        },
        sys.stdout,
    )


if __name__ == "__main__":
    main(sys.argv[1])
