#!/usr/bin/env python3
"""Rewrites an MCAP file with zstd-compressed chunks, keeping its header,
schemas, channels, metadata, attachments and every message (log and publish
times, sequence, data) byte for byte. Needs `pip install mcap zstandard`.

    python3 scripts/mcap-recompress.py IN.mcap OUT.mcap
"""
import sys

from mcap.reader import make_reader
from mcap.writer import CompressionType, Writer


def recompress(src: str, dst: str) -> int:
    with open(src, "rb") as fin, open(dst, "wb") as fout:
        reader = make_reader(fin)
        header = reader.get_header()
        summary = reader.get_summary()
        writer = Writer(fout, compression=CompressionType.ZSTD, chunk_size=1024 * 1024)
        writer.start(profile=header.profile, library=header.library)
        for schema in sorted(summary.schemas.values(), key=lambda s: s.id):
            writer.register_schema(schema.name, schema.encoding, schema.data)
        ids = {}
        for channel in sorted(summary.channels.values(), key=lambda c: c.id):
            ids[channel.id] = writer.register_channel(
                channel.topic, channel.message_encoding, channel.schema_id, channel.metadata
            )
            assert ids[channel.id] == channel.id, "channel ids must stay as they are"
        n = 0
        for _schema, channel, message in reader.iter_messages(log_time_order=False):
            writer.add_message(
                ids[channel.id], message.log_time, message.data, message.publish_time, message.sequence
            )
            n += 1
        for record in reader.iter_metadata():
            writer.add_metadata(record.name, record.metadata)
        for record in reader.iter_attachments():
            writer.add_attachment(record.log_time, record.create_time, record.name, record.media_type, record.data)
        writer.finish()
        return n


if __name__ == "__main__":
    print(f"{recompress(sys.argv[1], sys.argv[2])} messages")
