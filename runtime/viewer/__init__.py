"""tmpc.runtime.viewer: a plan as a self-contained animated HTML page (WebGL) and a PNG snapshot.
"""

from tmpc.runtime.viewer.page import write_html as write_html
from tmpc.runtime.viewer.page import write_png as write_png
from tmpc.runtime.viewer.page import html_page as html_page
from tmpc.runtime.viewer.page import page_data as page_data
