"""site_client.launch: a client under a skewed clock gets the args a plain
one does."""
import os
import re
import xml.etree.ElementTree as ET

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(
    os.path.abspath(__file__))))
SITE = os.path.join(ROOT, 'launch', 'site_client.launch')
CLIENT = os.path.join(ROOT, 'launch', 'client.launch')


def test_the_skewed_client_gets_every_arg_the_plain_one_does():
    root = ET.parse(SITE).getroot()
    (include,) = [e for e in root.iter('include')
                  if e.get('file', '').endswith('/client.launch')]
    plain = {a.get('name') for a in include.iter('arg')}
    (skewed,) = [n for n in root.iter('node')
                 if n.get('type') == 'skewed_client']
    client_args = next(a.get('value') for a in root.iter('arg')
                       if a.get('name') == 'client_args')
    given = set(re.findall(r"'?(\w+):=", skewed.get('args') + client_args))
    assert plain - {'client_id'} <= given, plain - given
    declared = {a.get('name') for a in ET.parse(CLIENT).getroot()
                .iter('arg')}
    assert plain <= declared and given - {'clock'} <= declared

